"""The S120's modes of operation through 0x6060 [4.3, 7]: velocity mode (VL, 2) and profile
velocity (PV, 3), both speed control behind the ramp-function generator, and profile torque
(PT, 4).

- The ramp-function generator ramps the speed setpoint toward the target with the ramp-up
  time p1120 (0 to p1082) while the speed rises and the ramp-down time p1121 while it falls
  (through zero on a reversal); 0 s ramps at once. The motor follows the ramp output through
  the axis' lag, torque-limited by p1520.
- PV: the target is 0x60FF (increments/s with an encoder, rpm without); statusword bit 10 when
  the ramp output has reached the target and the speed is within ``SPEED_TOLERANCE`` of it,
  bit 12 (speed = 0) below that tolerance. VL: the target is 0x6042 (rpm); no mode bits.
- PT: the torque setpoint follows 0x6071 (per mille of r0333) at once, limited by p1520; the
  load moves by inertia and friction, at most at p1082. Bit 10 when the setpoint is reached.
"""
from __future__ import annotations

from typing import Protocol, cast

from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import SW_OMS_12, SW_TARGET_REACHED
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.motion import clamp, velocity_step
from drive_bridge.sim.opmodes import OpMode

SPEED_TOLERANCE = 0.01  # of p1082: "setpoint reached" / "speed = 0" threshold


class S120ModeAxis(ModeAxis, Protocol):
    """What the S120 modes use of their axis beyond the generic one."""

    def speed_target(self, code: int) -> float: ...  # counts/s, limited to p1082

    def torque_target(self) -> float: ...  # per mille, limited to p1520


class RampedSpeed(OpMode):
    """VL or PV: speed control behind the ramp-function generator."""

    position_controlled = False

    def __init__(self, code: int) -> None:
        self.code = code

    def step(self, ax: ModeAxis, dt: float) -> None:
        target = cast(S120ModeAxis, ax).speed_target(self.code)
        ax.dp, ax.dv = velocity_step(ax.dp, ax.dv, target, ax.profile_acceleration(), ax.profile_deceleration(), dt)

    def status_bits(self, ax: ModeAxis) -> int:
        if self.code != Mode.PROFILE_VELOCITY:
            return 0
        tolerance = SPEED_TOLERANCE * ax.max_velocity()
        target = cast(S120ModeAxis, ax).speed_target(self.code)
        bits = 0
        if ax.dv == target and abs(ax.v - target) <= tolerance:
            bits |= SW_TARGET_REACHED
        if abs(ax.v) <= tolerance:
            bits |= SW_OMS_12
        return bits


class DirectTorque(OpMode):
    """PT: the torque setpoint is 0x6071, limited."""

    code = Mode.PROFILE_TORQUE
    position_controlled = False
    torque_controlled = True

    def enter(self, ax: ModeAxis) -> None:
        ax.dtorque = ax.torque

    def step(self, ax: ModeAxis, dt: float) -> None:
        limit = ax.torque_limit()
        ax.dtorque = clamp(cast(S120ModeAxis, ax).torque_target(), -limit, limit)

    def status_bits(self, ax: ModeAxis) -> int:
        return SW_TARGET_REACHED if abs(ax.dtorque - cast(S120ModeAxis, ax).torque_target()) < 0.5 else 0


def make_s120_mode(code: int) -> OpMode:
    """A fresh mode object for 2, 3 or 4; any other code holds the axis (no mode)."""
    if code in (Mode.VELOCITY, Mode.PROFILE_VELOCITY):
        return RampedSpeed(code)
    if code == Mode.PROFILE_TORQUE:
        return DirectTorque()
    mode = OpMode()
    mode.code = code
    return mode
