"""NMT slave states and commands, and the heartbeat consumer (0x1016).

canopen's NmtSlave neither re-sends the boot-up frame after a reset received from
the master nor gates PDOs, and runs its heartbeat on a python-can periodic thread;
the slave therefore keeps its own state with these small pieces.
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from canopen.sdo.exceptions import SdoAbortedError

NMT_COB_ID = 0x000
HEARTBEAT_BASE = 0x700
ABORT_PARAMETER_INCOMPATIBLE = 0x06040043


class NmtState(IntEnum):
    """Values as sent in the heartbeat byte (OFF: powered off, never on the bus)."""

    OFF = -1
    INITIALISING = 0
    STOPPED = 4
    OPERATIONAL = 5
    PRE_OPERATIONAL = 127

    @property
    def label(self) -> str:
        return self.name.replace('_', '-')


class NmtCommand(IntEnum):
    START = 0x01
    STOP = 0x02
    ENTER_PRE_OPERATIONAL = 0x80
    RESET_NODE = 0x81
    RESET_COMMUNICATION = 0x82


def addressed_command(data: bytes, node_id: int) -> NmtCommand | None:
    """The NMT command in ``data`` if it is for ``node_id`` (or all nodes), else None."""
    if len(data) != 2 or data[1] not in (0, node_id):
        return None
    try:
        return NmtCommand(data[0])
    except ValueError:
        return None  # e.g. command byte 0x00 (seen on real buses): ignored


def parse_consumer_entry(value: int) -> tuple[int, int]:
    """(producer node id, consumer time ms) of one 0x1016 entry."""
    return (value >> 16) & 0x7F, value & 0xFFFF


def check_consumer_entries(entries: dict[int, int]) -> None:
    """CiA 301: two active entries for one producer abort with 0x06040043."""
    seen: set[int] = set()
    for value in entries.values():
        node, time_ms = parse_consumer_entry(value)
        if node == 0 or time_ms == 0:
            continue
        if node in seen:
            raise SdoAbortedError(ABORT_PARAMETER_INCOMPATIBLE)
        seen.add(node)


@dataclass
class _Watch:
    timeout: float
    last: float | None = None  # None: no heartbeat seen yet (monitoring not started)
    lost: bool = False


class HeartbeatConsumer:
    """Monitors producers' heartbeats; monitoring of a producer starts with its first heartbeat."""

    def __init__(self) -> None:
        self._watches: dict[int, _Watch] = {}

    @property
    def producers(self) -> list[int]:
        return sorted(self._watches)

    def configure(self, entries: dict[int, int]) -> None:
        """Entries as stored in 0x1016 (sub -> value); re-arms every watch."""
        self._watches = {}
        for value in entries.values():
            node, time_ms = parse_consumer_entry(value)
            if node and time_ms:
                self._watches[node] = _Watch(time_ms / 1000.0)

    def heartbeat(self, node: int, now: float) -> bool:
        """Record a heartbeat; True if ``node`` was lost and is back."""
        watch = self._watches.get(node)
        if watch is None:
            return False
        watch.last = now
        recovered, watch.lost = watch.lost, False
        return recovered

    def expired(self, now: float) -> list[int]:
        """Producers whose heartbeat just timed out (each reported once per loss)."""
        lost = []
        for node, watch in self._watches.items():
            if watch.last is not None and not watch.lost and now - watch.last > watch.timeout:
                watch.lost = True
                lost.append(node)
        return lost

    def is_lost(self, node: int | None = None) -> bool:
        return any(w.lost for n, w in self._watches.items() if node is None or n == node)
