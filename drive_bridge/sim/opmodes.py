"""Modes of operation of a simulated CiA 402 axis: what drives the demand in
Operation Enabled, and the mode-specific statusword bits 10, 12 and 13.

One class per mode, all with the same small interface, so the axis state machine
(:mod:`drive_bridge.sim.axis402`) never tests mode numbers. Halt, quick stop and
fault ramps are the axis' business; a mode only runs while the axis is enabled and
not stopping, and is told to ``resume`` after a halt.

Choices CiA 402 leaves open:

- CSx and IP interpolate over the interpolation time period 0x60C2 (as Elmo, AKD:
  a master must set it to its SYNC period); without 0x60C2 in the EDS over 0x1006,
  else over the measured SYNC period. A set-point is reached one period after the
  SYNC that latched it; a late SYNC holds the last set-point, an early one starts the
  next segment from wherever the demand is.
- IP: an empty buffer holds the last point (no error); a halt pauses consumption
  and, released, continues from the stopped position to the next point.
- PV bit 12 "speed = 0" uses the velocity window 0x606D as threshold (0x606F is not
  in the generic EDS).
- HM: halt or bit 4 falling interrupts homing; the attained bit stays until the next
  start; the home switch is a point, found from either side.
"""
from __future__ import annotations

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import CW_OMS_4, CW_OMS_5, CW_OMS_6, SW_OMS_12, SW_OMS_13, SW_TARGET_REACHED
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.motion import Segment, clamp, position_step, ramp_value, stop_step, velocity_step

POSITION_WINDOW = 0x6067
POSITION_WINDOW_TIME = 0x6068
VELOCITY_WINDOW = 0x606D
VELOCITY_WINDOW_TIME = 0x606E
TORQUE_SLOPE = 0x6087


def _rising(prev: int, cw: int, bit: int) -> bool:
    return bool(cw & bit) and not prev & bit


def _falling(prev: int, cw: int, bit: int) -> bool:
    return bool(prev & bit) and not cw & bit


class _Window:
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
        self.window = _Window()

    def enter(self, ax: ModeAxis) -> None:
        self.target, self.pending, self.ack, self.arrived = None, None, False, True
        self.base = ax.dp
        self.window.reset()

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        if _falling(prev, cw, CW_OMS_4):
            self.ack = False
        if not _rising(prev, cw, CW_OMS_4):
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
        self.window = _Window()

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


# homing methods -> search direction (+1 / -1); 0: toward the switch (home switch methods)
_HOMING_DIRECTIONS: dict[int, int] = {1: -1, 17: -1, 33: -1, 2: 1, 18: 1, 34: 1}
_HOMING_DIRECTIONS.update({m: 0 for m in (*range(3, 15), *range(19, 31))})
HOME_HERE = (35, 37)


class Homing(OpMode):
    """HM: methods 35/37 make the actual position the home offset 0x607C; methods
    1..34 (less the reserved 15, 16, 31, 32) search the simulated switch at
    0x6099:1, creep back to it at 0x6099:2 (acceleration 0x609A), and define its
    position as the home offset. Bit 4 rising starts, falling interrupts; timeout or
    an unsupported method sets the homing error bit 13."""

    code = Mode.HOMING

    def __init__(self) -> None:
        self.phase = 'idle'  # idle, search, creep, done, error, interrupted
        self.direction = 1
        self.elapsed = 0.0

    def enter(self, ax: ModeAxis) -> None:
        self.phase = 'idle'

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        if _rising(prev, cw, CW_OMS_4):
            self._start(ax)
        elif _falling(prev, cw, CW_OMS_4) and self.phase in ('search', 'creep'):
            self.phase = 'interrupted'

    def resume(self, ax: ModeAxis) -> None:
        if self.phase in ('search', 'creep'):
            self.phase = 'interrupted'  # a halt ends the run; bit 4 must rise again

    def _start(self, ax: ModeAxis) -> None:
        method = ax.param(obj.HOMING_METHOD, default=0)
        self.elapsed = 0.0
        if method in HOME_HERE:
            ax.shift_position(ax.param(obj.HOME_OFFSET, default=0) - ax.p)
            self.phase = 'done'
        elif method in _HOMING_DIRECTIONS:
            direction = _HOMING_DIRECTIONS[method]
            if direction == 0:
                direction = 1 if ax.switch_position >= ax.dp else -1
            self.direction = direction
            self.phase = 'search'
        else:
            self.phase = 'error'

    def step(self, ax: ModeAxis, dt: float) -> None:
        acc = max(1.0, float(ax.param(obj.HOMING_ACCELERATION, default=ax.profile_acceleration())))
        if self.phase in ('search', 'creep'):
            self.elapsed += dt
            if self.elapsed > ax.homing_timeout:
                self.phase = 'error'
        if self.phase == 'search':
            speed = min(ax.max_velocity(), float(ax.param(obj.HOMING_SPEEDS, 1, default=1000)))
            before = ax.dp
            ax.dp, ax.dv = velocity_step(ax.dp, ax.dv, self.direction * speed, acc, acc, dt)
            if ((ax.dp - ax.switch_position) * self.direction >= 0 > (before - ax.switch_position) * self.direction
                    or before == ax.switch_position):
                self.phase = 'creep'
        elif self.phase == 'creep':
            speed = min(ax.max_velocity(), float(ax.param(obj.HOMING_SPEEDS, 2, default=100)))
            ax.dp, ax.dv, arrived = position_step(ax.dp, ax.dv, ax.switch_position, max(speed, 1.0), acc, acc, dt)
            if arrived:
                ax.shift_position(ax.param(obj.HOME_OFFSET, default=0) - ax.switch_position)
                self.phase = 'done'
        else:
            ax.dp, ax.dv = stop_step(ax.dp, ax.dv, acc, dt)

    def status_bits(self, ax: ModeAxis) -> int:
        stopped = ax.standstill()
        if self.phase in ('search', 'creep'):
            return 0
        if self.phase == 'done':
            return SW_OMS_12 | (SW_TARGET_REACHED if stopped else 0)
        if self.phase == 'error':
            return SW_OMS_13 | (SW_TARGET_REACHED if stopped else 0)
        return SW_TARGET_REACHED if stopped else 0


class InterpolatedPosition(OpMode):
    """IP, linear sub-mode: with bit 4 set (IP active, statusword bit 12) one buffered
    0x60C1:1 point is consumed per SYNC (or per 0x60C2 period of the drive's own clock
    when no SYNC comes) and the demand moves linearly to it over the period 0x60C2.
    An empty buffer holds the last point."""

    code = Mode.INTERPOLATED_POSITION

    def __init__(self) -> None:
        self.active = False
        self.segment: Segment | None = None

    def enter(self, ax: ModeAxis) -> None:
        self.active = bool(ax.controlword & CW_OMS_4)
        self.segment = None

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        self.active = bool(cw & CW_OMS_4)

    def on_sync(self, ax: ModeAxis) -> None:
        if self.active:
            self._consume(ax)

    def resume(self, ax: ModeAxis) -> None:
        self.segment = None

    def _consume(self, ax: ModeAxis) -> None:
        if ax.ip:
            point = ax.limit_target(float(ax.ip.pop()))
            self.segment = Segment(ax.dp, point, ax.interpolation_period())

    def step(self, ax: ModeAxis, dt: float) -> None:
        if self.active and not ax.sync_driven and (self.segment is None or self.segment.done):
            self._consume(ax)  # no SYNC: the drive's own clock paces the buffer
        if self.segment is None:
            super().step(ax, dt)
            return
        ax.dp = self.segment.advance(dt)
        ax.dv = self.segment.slope

    def status_bits(self, ax: ModeAxis) -> int:
        bits = SW_OMS_12 if self.active else 0
        if ax.fe_active:
            bits |= SW_OMS_13
        if not ax.ip and (self.segment is None or self.segment.done) and ax.standstill():
            bits |= SW_TARGET_REACHED
        return bits


class CyclicSynchronous(OpMode):
    """CSP/CSV/CST: the target (0x607A + 0x60B0, 0x60FF + 0x60B1, 0x6071 + 0x60B2) is
    latched at each SYNC and reached linearly over the interpolation period 0x60C2.
    Bit 12: the drive follows the command value (not while halted); bit 13 (CSP):
    following error."""

    code: int = Mode.CYCLIC_SYNC_POSITION

    def __init__(self, code: int) -> None:
        self.code = code
        self.position_controlled = code == Mode.CYCLIC_SYNC_POSITION
        self.torque_controlled = code == Mode.CYCLIC_SYNC_TORQUE
        self.segment: Segment | None = None

    def enter(self, ax: ModeAxis) -> None:
        self.segment = None
        if self.torque_controlled:
            ax.dtorque = ax.torque

    def resume(self, ax: ModeAxis) -> None:
        self.segment = None

    def on_sync(self, ax: ModeAxis) -> None:
        if ax.halted:
            return
        period = ax.interpolation_period()
        if self.code == Mode.CYCLIC_SYNC_POSITION:
            target = float(ax.param(obj.TARGET_POSITION)) + ax.param(obj.POSITION_OFFSET, default=0)
            self.segment = Segment(ax.dp, ax.limit_target(target), period)
        elif self.code == Mode.CYCLIC_SYNC_VELOCITY:
            limit = ax.max_velocity()
            target = float(ax.param(obj.TARGET_VELOCITY)) + ax.param(obj.VELOCITY_OFFSET, default=0)
            self.segment = Segment(ax.dv, clamp(target, -limit, limit), period)
        else:
            limit = ax.torque_limit()
            target = float(ax.param(obj.TARGET_TORQUE)) + ax.param(obj.TORQUE_OFFSET, default=0)
            self.segment = Segment(ax.dtorque, clamp(target, -limit, limit), period)

    def step(self, ax: ModeAxis, dt: float) -> None:
        segment = self.segment
        if segment is None:
            if self.torque_controlled:
                return
            super().step(ax, dt)
            return
        if self.code == Mode.CYCLIC_SYNC_POSITION:
            ax.dv = segment.slope
            ax.dp = segment.advance(dt)
        elif self.code == Mode.CYCLIC_SYNC_VELOCITY:
            v_new = segment.advance(dt)
            ax.dp += 0.5 * (ax.dv + v_new) * dt
            ax.dv = v_new
        else:
            ax.dtorque = segment.advance(dt)

    def status_bits(self, ax: ModeAxis) -> int:
        bits = 0 if ax.halted else SW_OMS_12
        if ax.fe_active and self.position_controlled:
            bits |= SW_OMS_13
        if ax.halted and ax.standstill():
            bits |= SW_TARGET_REACHED
        return bits


def make_mode(code: int) -> OpMode:
    """A fresh mode object for a mode code (the code was validated against 0x6502)."""
    if code == Mode.PROFILE_POSITION:
        return ProfilePosition()
    if code == Mode.PROFILE_VELOCITY:
        return ProfileVelocity()
    if code == Mode.PROFILE_TORQUE:
        return ProfileTorque()
    if code == Mode.HOMING:
        return Homing()
    if code == Mode.INTERPOLATED_POSITION:
        return InterpolatedPosition()
    if code in (Mode.CYCLIC_SYNC_POSITION, Mode.CYCLIC_SYNC_VELOCITY, Mode.CYCLIC_SYNC_TORQUE):
        return CyclicSynchronous(code)
    mode = OpMode()
    mode.code = code
    return mode


IMPLEMENTED_MODES = frozenset({Mode.NO_MODE, Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE,
                               Mode.HOMING, Mode.INTERPOLATED_POSITION, Mode.CYCLIC_SYNC_POSITION,
                               Mode.CYCLIC_SYNC_VELOCITY, Mode.CYCLIC_SYNC_TORQUE})
