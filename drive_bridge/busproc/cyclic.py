"""The cyclic state, bus process -> node process: every joint's feedback once per cycle.

Sent as soon as a cycle's synchronous TPDOs are in (the joint states' stamps are their
reception times), or at the next SYNC when some did not come; packed with ``struct`` (no
pickling on the cycle's path: about 1 us per joint) and sent without waiting. A message the
node process's full buffer cannot take is dropped and counted: the next cycle's replaces it.
The header also carries the count of reports the bus process's outbox dropped (``outbox``):
this lane is not the one a full outbox waits on, so the count reaches the node every cycle.

Layout: header (sequence number, stream lag in s, executor stalls, the cyclic states the
sender dropped, the reports its outbox dropped), then per joint in configuration order:
available, position, velocity, effort (SI), stamp (epoch s).
"""
from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass

_HEADER = struct.Struct('<IdIII')
_JOINT = struct.Struct('<?dddd')

Feedback = tuple[bool, float, float, float, float]  # JointDriver.feedback()


@dataclass(frozen=True)
class CyclicState:
    """One cycle's state as the node process reads it."""

    sequence: int
    lag: float  # s the trajectory stream clock is behind the wall clock
    stalls: int  # stalled cycles the executor has absorbed so far
    dropped: int  # cyclic states the bus process could not send so far (node's buffer full)
    reports_dropped: int  # reports (events, EMCY, trajectory states...) its full outbox dropped so far
    joints: tuple[Feedback, ...]  # in the configuration's joint order


def size(joints: int) -> int:
    return _HEADER.size + joints * _JOINT.size


def pack(sequence: int, lag: float, stalls: int, dropped: int, joints: Sequence[Feedback], *,
         reports_dropped: int = 0) -> bytes:
    parts = [_HEADER.pack(sequence & 0xFFFFFFFF, lag, stalls & 0xFFFFFFFF, dropped & 0xFFFFFFFF,
                          reports_dropped & 0xFFFFFFFF)]
    parts.extend(_JOINT.pack(*feedback) for feedback in joints)
    return b''.join(parts)


def unpack(data: bytes, joints: int) -> CyclicState:
    """ValueError when ``data`` is not a state of ``joints`` joints."""
    if len(data) != size(joints):
        raise ValueError(f'cyclic state of {len(data)} bytes, expected {size(joints)} for {joints} joint(s)')
    sequence, lag, stalls, dropped, reports_dropped = _HEADER.unpack_from(data, 0)
    offset = _HEADER.size
    values = []
    for _ in range(joints):
        values.append(_JOINT.unpack_from(data, offset))
        offset += _JOINT.size
    return CyclicState(sequence, lag, stalls, dropped, reports_dropped, tuple(values))
