"""The base of a simulated mode of operation (CiA 402 0x6060): the interface every mode
object has, the hold it does by default, and what several modes share (controlword edges,
the target window with its hold time)."""
from __future__ import annotations

from drive_bridge.cia402.modes import Mode
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.motion import stop_step

POSITION_WINDOW = 0x6067
POSITION_WINDOW_TIME = 0x6068
VELOCITY_WINDOW = 0x606D
VELOCITY_WINDOW_TIME = 0x606E
TORQUE_SLOPE = 0x6087


def rising(prev: int, cw: int, bit: int) -> bool:
    return bool(cw & bit) and not prev & bit


def falling(prev: int, cw: int, bit: int) -> bool:
    return bool(prev & bit) and not cw & bit


class TargetWindow:
    """'Inside a window for at least a time' (target reached with 0x6067/0x6068, 0x606D/0x606E)."""

    def __init__(self) -> None:
        self.inside_for = -1.0  # < 0: outside

    def update(self, inside: bool, dt: float) -> None:
        self.inside_for = (max(self.inside_for, 0.0) + dt) if inside else -1.0

    def reached(self, hold_time: float) -> bool:
        return self.inside_for >= 0.0 and self.inside_for >= hold_time - 1e-9

    def reset(self) -> None:
        self.inside_for = -1.0


class OpMode:
    """Base: hold the demand (decelerating to standstill), no mode bits."""

    code: int = Mode.NO_MODE
    position_controlled: bool = True  # following error (0x6065/0x6066) monitored
    torque_controlled: bool = False  # the plant is driven by the demand torque

    def enter(self, ax: ModeAxis) -> None:
        """Operation Enabled reached in this mode, or mode switched while enabled."""

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        """Controlword written while Operation Enabled (edges of bits 4..6)."""

    def on_sync(self, ax: ModeAxis) -> None:
        """SYNC: the model has stepped to now; latch new set-points."""

    def step(self, ax: ModeAxis, dt: float) -> None:
        ax.dp, ax.dv = stop_step(ax.dp, ax.dv, ax.profile_deceleration(), dt)

    def post_step(self, ax: ModeAxis, dt: float) -> None:
        """After the plant moved: window timers for target reached."""

    def resume(self, ax: ModeAxis) -> None:
        """Halt released."""

    def status_bits(self, ax: ModeAxis) -> int:
        return 0

