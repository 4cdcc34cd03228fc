"""The simulated OPEN drive's alarms A0..A15 (0x2018): an alarm trips once and latches, an EMCY
when its bit in P163 (0x2019) enables it; an alarm reset clears those whose cause is gone, with
EMCY 0x0000 carrying the rest; a cause that persists trips its alarm again at boot."""
from __future__ import annotations

from collections.abc import Callable

from drive_bridge.sim.opendrive import objects as o
from drive_bridge.sim.opendrive.emcy import OpenDriveEmcy


class Alarms:
    """``active``: bit n = alarm An latched; ``causes``: bit n = its cause persists."""

    def __init__(self, emcy: OpenDriveEmcy, enabled: Callable[[], int]) -> None:
        self._emcy = emcy
        self._enabled = enabled
        self.active = 0
        self.causes = 0

    def trip(self, number: int) -> None:
        bit = 1 << number
        if self.active & bit:
            return  # latched already: no new event
        self.active |= bit
        if self._enabled() & bit:
            self._emcy.alarm_event(o.EMCY_GENERIC, self.active, history=True)

    def reset(self) -> None:
        """Alarm reset: the alarms whose cause is gone are cleared, EMCY 0x0000 with the rest."""
        cleared = self.active & ~self.causes
        if not cleared:
            return
        self.active &= ~cleared
        self._emcy.alarm_event(o.EMCY_RESET, self.active, history=False)

    def trip_persisting(self) -> None:
        """At boot: causes still present trip their alarm again."""
        for number in range(16):
            if self.causes >> number & 1:
                self.trip(number)
