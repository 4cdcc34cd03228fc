"""The CiA 402 profile modes of a simulated axis: profile position (pp, with the set-point
handshake), profile velocity (pv) and profile torque (tq)."""
from __future__ import annotations

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import CW_OMS_4, CW_OMS_5, CW_OMS_6, SW_OMS_12, SW_OMS_13, SW_TARGET_REACHED
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.motion import clamp, position_step, ramp_value, velocity_step
from drive_bridge.sim.opmode import (
    POSITION_WINDOW,
    POSITION_WINDOW_TIME,
    TORQUE_SLOPE,
    VELOCITY_WINDOW,
    VELOCITY_WINDOW_TIME,
    OpMode,
    TargetWindow,
    falling,
    rising,
)


class ProfilePosition(OpMode):
    """PP with the set-point handshake: bit 4 rising edge latches 0x607A (bit 6:
    relative to the preceding target), bit 12 acknowledges while bit 4 is held or a
    buffered set-point waits, bit 5 replaces the running target at once, otherwise
    the next set-point starts when the running one is reached."""

    code = Mode.PROFILE_POSITION

    def __init__(self) -> None:
        self.target: float | None = None
        self.pending: float | None = None
        self.ack = False
        self.base = 0.0
        self.arrived = True
        self.window = TargetWindow()

    def enter(self, ax: ModeAxis) -> None:
        self.target, self.pending, self.ack, self.arrived = None, None, False, True
        self.base = ax.dp
        self.window.reset()

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        if falling(prev, cw, CW_OMS_4):
            self.ack = False
        if not rising(prev, cw, CW_OMS_4):
            return
        immediately = bool(cw & CW_OMS_5)
        if self.pending is not None and not immediately:
            return  # set-point buffer full: the edge is not acknowledged
        target = float(ax.param(obj.TARGET_POSITION))
        if cw & CW_OMS_6:
            target += self.base
        target = ax.limit_target(target)
        self.base = target
        if immediately or self.target is None or self.arrived:
            self.target, self.pending = target, None
            self.arrived = False
        else:
            self.pending = target
        self.ack = True
        self.window.reset()

    def step(self, ax: ModeAxis, dt: float) -> None:
        if self.target is None:
            super().step(ax, dt)
            return
        if self.arrived:
            ax.dv = 0.0
            return
        ax.dp, ax.dv, self.arrived = position_step(ax.dp, ax.dv, self.target, ax.profile_velocity(),
                                                   ax.profile_acceleration(), ax.profile_deceleration(), dt)
        if self.arrived and self.pending is not None:
            self.target, self.pending, self.arrived = self.pending, None, False
            self.window.reset()

    def post_step(self, ax: ModeAxis, dt: float) -> None:
        inside = (self.target is None
                  or (self.arrived and abs(ax.p - self.target) <= ax.param(POSITION_WINDOW, default=0)))
        self.window.update(inside, dt)

    def status_bits(self, ax: ModeAxis) -> int:
        bits = 0
        if self.ack or self.pending is not None:
            bits |= SW_OMS_12
        if ax.fe_active:
            bits |= SW_OMS_13
        if self.target is None or (self.pending is None
                                   and self.window.reached(ax.param(POSITION_WINDOW_TIME, default=0) / 1000.0)):
            bits |= SW_TARGET_REACHED
        return bits


class ProfileVelocity(OpMode):
    """PV: ramp to 0x60FF with 0x6083/0x6084; bit 10 inside 0x606D for 0x606E ms; bit 12 speed = 0."""

    code = Mode.PROFILE_VELOCITY
    position_controlled = False

    def __init__(self) -> None:
        self.window = TargetWindow()

    def enter(self, ax: ModeAxis) -> None:
        self.window.reset()

    def target(self, ax: ModeAxis) -> float:
        limit = ax.max_velocity()
        return clamp(float(ax.param(obj.TARGET_VELOCITY)), -limit, limit)

    def step(self, ax: ModeAxis, dt: float) -> None:
        ax.dp, ax.dv = velocity_step(ax.dp, ax.dv, self.target(ax), ax.profile_acceleration(),
                                     ax.profile_deceleration(), dt)

    def post_step(self, ax: ModeAxis, dt: float) -> None:
        self.window.update(abs(ax.v - self.target(ax)) <= ax.param(VELOCITY_WINDOW, default=0), dt)

    def status_bits(self, ax: ModeAxis) -> int:
        bits = 0
        if self.window.reached(ax.param(VELOCITY_WINDOW_TIME, default=0) / 1000.0):
            bits |= SW_TARGET_REACHED
        if abs(ax.v) <= ax.param(VELOCITY_WINDOW, default=0):
            bits |= SW_OMS_12  # speed = 0
        return bits


class ProfileTorque(OpMode):
    """PT: the demand torque follows 0x6071 with the slope 0x6087; the load moves by
    inertia and friction (speed limited by 0x6080)."""

    code = Mode.PROFILE_TORQUE
    position_controlled = False
    torque_controlled = True

    def enter(self, ax: ModeAxis) -> None:
        ax.dtorque = ax.torque

    def target(self, ax: ModeAxis) -> float:
        limit = ax.torque_limit()
        return clamp(float(ax.param(obj.TARGET_TORQUE)), -limit, limit)

    def step(self, ax: ModeAxis, dt: float) -> None:
        ax.dtorque = ramp_value(ax.dtorque, self.target(ax), ax.param(TORQUE_SLOPE, default=1e9), dt)

    def status_bits(self, ax: ModeAxis) -> int:
        return SW_TARGET_REACHED if abs(ax.dtorque - self.target(ax)) < 0.5 else 0

