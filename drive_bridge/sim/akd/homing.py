"""Homing mode of the AKD: the generic model, but no target-reached bit before the first run
(the manual reads 0x0237 after enabling in homing mode), and 0x1002 learns 'homed'."""
from __future__ import annotations

from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.opmodes import Homing


class AkdHoming(Homing):
    """Homing with the AKD's statusword and 'homed' flag (module docstring)."""

    def status_bits(self, ax: ModeAxis) -> int:
        if self.phase == 'idle':
            return 0
        if self.phase == 'done':
            ax.homed = True  # type: ignore[attr-defined]
        return super().status_bits(ax)
