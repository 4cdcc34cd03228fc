"""Bus process -> node process: answers, state changes, events, EMCY and frames.

On the request lane (the cyclic joint states have a lane of their own, :mod:`.cyclic`):
answers to requests (:class:`Reply`, :class:`Failure`), axis snapshots when an axis's
state changes (:class:`AxisStates`), the master's events (``master.events.BusEvent``),
EMCYs within the reporting rate limit (``cia301.emcy.EmcyEvent``), trajectory handle
changes (:class:`HandleState`), refused direct commands (:class:`CommandRefused`) and
frames for recording in bounded batches (:class:`Frames`). A sender thread in the bus
process sends them from a bounded queue: nothing on the cycle's path waits for the node.
"""
from __future__ import annotations

import struct
from collections.abc import Iterable
from dataclasses import dataclass

from drive_bridge.joint.snapshot import AxisSnapshot
from drive_bridge.joint.strategy import StreamStrategy
from drive_bridge.master.master import BusSnapshot
from drive_bridge.streaming.pvt import PvtStats

FRAMES_PER_BATCH = 2000  # frames per Frames message (~42 kB)
_FRAME = struct.Struct('<dIBB8s')  # timestamp, arbitration id, flags, dlc, data (a CAN FD frame: its first 8)
_EXTENDED, _REMOTE, _ERROR, _RX, _FD = 1, 2, 4, 8, 16

# timestamp, id, extended, remote, error, dlc, data, received (not sent), CAN FD
FrameFields = tuple[float, int, bool, bool, bool, int, bytes, bool, bool]


@dataclass(frozen=True)
class Ready:
    """The bus is open and the nodes boot; ``pid`` of the bus process."""

    pid: int
    joints: tuple[str, ...]
    messages: tuple[str, ...] = ()  # what the bus process has to say at start (e.g. the simulation)


@dataclass(frozen=True)
class StartFailed:
    message: str


@dataclass(frozen=True)
class Reply:
    id: int
    value: object = None


@dataclass(frozen=True)
class AxisStates:
    """The joints whose state, mode or flags changed (or all, every ``outbox.REFRESH``), with
    what their drivers say of the current mode: the field a direct command carries and how a
    trajectory is streamed (None: none). ``taken`` is the bus process's monotonic time just
    before the snapshots were read: reports and stop answers travel on different lanes, read by
    different threads, so the node applies a joint's snapshot only if none taken later was
    applied before (an older report never undoes a quick stop's answer)."""

    snapshots: tuple[AxisSnapshot, ...]
    command_fields: tuple[str | None, ...]
    strategies: tuple[StreamStrategy | None, ...]
    taken: float = 0.0


@dataclass(frozen=True)
class Failure:
    """A request that failed: ``kind`` names the error class (``sdo``, ``joint``,
    ``trajectory``, ``parameter``, ``value``, ``timeout``, ``busy``, ``boundary``,
    ``internal``) so the node raises the same kind; SDO failures carry their address and abort
    code."""

    id: int
    kind: str
    message: str
    abort_code: int = 0
    node_id: int = 0
    index: int = 0
    subindex: int = 0
    reason: str = ''  # SdoError.reason: the message without the address
    states: AxisStates | None = None  # an axis intent's joint after the failure (e.g. its mode restored)


@dataclass(frozen=True)
class StopOutcome:
    """The answer to a stop: per joint '' (done) or the error, and the joints' states after it."""

    errors: tuple[tuple[str, str], ...]
    states: AxisStates


@dataclass(frozen=True)
class HandleState:
    """A trajectory's handle: its time span and how it ended (``TrajectoryHandle``'s fields)."""

    id: int
    joints: tuple[str, ...]
    start: float
    end: float
    state: str
    reason: str = ''
    notes: tuple[str, ...] = ()  # what planning changed (past points dropped, segments stretched)
    warnings: tuple[str, ...] = ()  # what it could not check (a joint without a velocity limit)


@dataclass(frozen=True)
class FeederState:
    """A PVT joint's feeder, for tests and diagnosis: its counts, whether its motion was closed
    (the time-0 point sent), and the stream time up to which points are committed."""

    stats: PvtStats
    ended: bool
    horizon: float | None


@dataclass(frozen=True)
class CommandRefused:
    topic: str
    reason: str


@dataclass(frozen=True)
class Frames:
    """``count`` frames packed back to back (:func:`pack_frames`); ``dropped``: frames the bus
    process could not forward so far (its queue was full)."""

    data: bytes
    count: int
    dropped: int


@dataclass(frozen=True)
class Farewell:
    """The bus process ends on purpose (``reason``) after stopping the axes and the bus; ``final``:
    the bus as it was then (its traffic counts are the last: a recording can be checked against
    them)."""

    reason: str
    final: BusSnapshot | None = None


def pack_frames(frames: Iterable[FrameFields]) -> tuple[bytes, int]:
    parts = []
    for timestamp, can_id, extended, remote, error, dlc, data, rx, fd in frames:
        flags = (_EXTENDED if extended else 0) | (_REMOTE if remote else 0) | (_ERROR if error else 0) \
            | (_RX if rx else 0) | (_FD if fd else 0)
        parts.append(_FRAME.pack(timestamp, can_id, flags, dlc, bytes(data[:8])))
    return b''.join(parts), len(parts)


def unpack_frames(data: bytes) -> list[FrameFields]:
    frames: list[FrameFields] = []
    for timestamp, can_id, flags, dlc, payload in _FRAME.iter_unpack(data):
        frames.append((timestamp, can_id, bool(flags & _EXTENDED), bool(flags & _REMOTE), bool(flags & _ERROR),
                       dlc, bytes(payload[:min(dlc, 8)]), bool(flags & _RX), bool(flags & _FD)))
    return frames
