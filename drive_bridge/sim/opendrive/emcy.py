"""The OPEN drive's EMCY (§2.6): only two codes, 0x1000 when an enabled alarm trips and
0x0000 when alarms are reset; bytes 3-4 carry the alarm word (0x2018), bytes 5-7 are 0;
the error register comes from the alarms; 0x1003 keeps (alarm word << 16) | code for each
alarm event (up to 32, newest at sub 1), reset events not included."""
from __future__ import annotations

from collections.abc import Callable

from drive_bridge.sim.emcy import ERROR_HISTORY, EmcyProducer
from drive_bridge.sim.opendrive.objects import register_of
from drive_bridge.sim.store import ObjectStore, key


class OpenDriveEmcy(EmcyProducer):
    """EMCY frames and history of the alarm word; CiA 301 errors of other sources are not
    signalled (the drive uses no other code)."""

    def __init__(self, store: ObjectStore, send: Callable[[int, bytes], None]) -> None:
        super().__init__(store, send)
        self.alarms: Callable[[], int] = lambda: 0  # the drive's present alarm word (set by the drive)

    @property
    def register(self) -> int:
        return register_of(self.alarms())

    def error(self, code: int, source: str = 'device', manufacturer: bytes = b'',
              transient: bool = False, emit: bool = True) -> None:
        """Generic CiA 301 errors (PDO length): the drive has no EMCY code for them."""

    def clear(self, source: str | None = None) -> None:
        """Generic CiA 301 errors end: nothing to signal."""

    def alarm_event(self, code: int, alarms: int, history: bool) -> None:
        """One EMCY with ``code`` and the alarm word; ``history``: also a 0x1003 entry."""
        alarms &= 0xFFFF
        if history and self.history_size:
            values = self.store.values
            for sub in range(self.history_size, 1, -1):
                values[key(ERROR_HISTORY, sub)] = values[key(ERROR_HISTORY, sub - 1)]
            values[key(ERROR_HISTORY, 1)] = alarms << 16 | code & 0xFFFF
            values[key(ERROR_HISTORY, 0)] = min(self.history_size, values[key(ERROR_HISTORY, 0)] + 1)
        self.emit(code, register_of(alarms), alarms.to_bytes(2, 'little'))
