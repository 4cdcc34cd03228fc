"""The SERVOSTAR's modes of operation [4.6, 4.7, 5, 6]: the manufacturer modes (negative numbers)
next to the CiA 402 pp, pv and hm of :mod:`drive_bridge.sim.opmodes`.

Units inside the model: counts = 2^20 per motor revolution, counts/s. The axis converts the
drive's objects (2^PRBASE increments, 1875/262144 rpm, user units, ramp times in ms).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from drive_bridge.cia402.statemachine import CW_OMS_4, SW_OMS_12, SW_TARGET_REACHED
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.motion import clamp, position_step, stop_step, velocity_step
from drive_bridge.sim.opmodes import Homing, OpMode, ProfilePosition
from drive_bridge.sim.servostar.objects import (
    CURRENT_DIGITAL,
    HOMING,
    HOMING_MANUFACTURER,
    JOG,
    POSITION,
    PROFILE_POSITION,
    RATED_CURRENT_COUNTS,
    SPEED_DIGITAL,
    TRAJECTORY,
)

SPEED_ZERO = 2 ** 20 / 60.0  # counts/s (1 rpm): "speed 0" for statusword bit 12 and 0x1002 bit 28


class StarAxis(ModeAxis, Protocol):
    """What the SERVOSTAR's modes use of their axis beyond a CiA 402 mode's."""

    toggle: bool
    homed: bool
    task_active: bool
    trajectory_target: float

    def vlim(self) -> float: ...

    def trajectory_period(self) -> float: ...

    def trajectory_setpoint(self) -> float | None: ...

    def digital_setpoint(self) -> int: ...

    def ramp(self, time_ms: float, speed: float) -> float: ...

    def user_to_counts(self, value: float) -> float: ...

    def trajectory_clamped(self, step: float, limit: float) -> None: ...


def _rising(prev: int, cw: int, bit: int) -> bool:
    return bool(cw & bit) and not prev & bit


class Trajectory(OpMode):
    """0xFA: each SYNC takes the setpoint 0x2022:04 received before it (RPDO 33 / 41 or SDO): the
    commanded position moves linearly from where it is to that setpoint over PTBASE and then
    holds (a SYNC interval longer than PTBASE makes the speed profile dip, a shorter one starts
    the next segment early). The demand follows the command at most at VLIM, so a step beyond
    VLIM x PTBASE falls behind and the following error (command - actual) grows; the axis checks
    it against PEMAX."""

    code = TRAJECTORY

    def __init__(self) -> None:
        self.start = self.target = self.command = 0.0
        self.elapsed = 0.0
        self.period = 0.001
        self.segments = 0

    def enter(self, ax: ModeAxis) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        self.start = self.target = self.command = star.trajectory_target = ax.dp  # hold here until a setpoint
        self.elapsed = self.period = 1.0

    def on_sync(self, ax: ModeAxis) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        target = star.trajectory_setpoint()
        if target is None:
            return
        period = star.trajectory_period()
        limit = star.vlim() * period
        step = abs(target - self.target)
        if step > limit:
            star.trajectory_clamped(step, limit)
        self.start, self.target, self.elapsed, self.period = self.command, target, 0.0, period
        self.segments += 1

    def step(self, ax: ModeAxis, dt: float) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        self.elapsed += dt
        fraction = min(self.elapsed / self.period, 1.0) if self.period > 0 else 1.0
        self.command = self.start + (self.target - self.start) * fraction
        reach = star.vlim() * dt
        before = ax.dp
        ax.dp = before + clamp(self.command - before, -reach, reach)
        ax.dv = (ax.dp - before) / dt

    def following_error(self, ax: ModeAxis) -> float:
        return self.command - ax.p

    def status_bits(self, ax: ModeAxis) -> int:
        done = self.elapsed >= self.period and abs(self.command - ax.dp) < 1.0
        return SW_TARGET_REACHED if done and ax.standstill() else 0


class DigitalSpeed(OpMode):
    """0xFE: speed setpoint 0x2060 (1 bit = 1875/262144 rpm = 125 counts/s), limited to VLIM, ramps
    ACC / DEC (ms from 0 to VLIM); statusword bit 12 = speed 0."""

    code = SPEED_DIGITAL
    position_controlled = False

    def step(self, ax: ModeAxis, dt: float) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        limit = star.vlim()
        target = clamp(star.digital_setpoint() * 125.0, -limit, limit)
        ax.dp, ax.dv = velocity_step(ax.dp, ax.dv, target, ax.profile_acceleration(), ax.profile_deceleration(), dt)

    def status_bits(self, ax: ModeAxis) -> int:
        return SW_OMS_12 if abs(ax.v) < SPEED_ZERO else 0


class DigitalCurrent(OpMode):
    """0xFD: current setpoint 0x2060 (1640 = rated current = rated torque, 3280 = peak)."""

    code = CURRENT_DIGITAL
    position_controlled = False
    torque_controlled = True

    def enter(self, ax: ModeAxis) -> None:
        ax.dtorque = ax.torque

    def step(self, ax: ModeAxis, dt: float) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        limit = ax.torque_limit()
        ax.dtorque = clamp(star.digital_setpoint() * 1000.0 / RATED_CURRENT_COUNTS, -limit, limit)


class Jog(OpMode):
    """0xF8: runs at VJOG (0x2024:07, user units/s) with the ramps ACCR / DECR (ms to that speed)
    while enabled (the manual documents no start bit)."""

    code = JOG
    position_controlled = False

    def step(self, ax: ModeAxis, dt: float) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        speed = clamp(star.user_to_counts(ax.param(0x2024, 7, default=0)), -star.vlim(), star.vlim())
        acc = star.ramp(ax.param(0x2024, 4, default=10), abs(speed) or star.vlim())
        dec = star.ramp(ax.param(0x2024, 5, default=10), abs(speed) or star.vlim())
        ax.dp, ax.dv = velocity_step(ax.dp, ax.dv, speed, acc, dec, dt)


class ManufacturerHoming(OpMode):
    """0xF9: controlword bit 4 rising starts homing type NREF (0x2024:01): 0 makes the actual
    position the reference offset ROFFS, 6 the position setpoint; 1-5 move at VREF (ramps ACCR /
    DECR) to the simulated home switch and make it ROFFS. 0x1002 bit 16 while it runs, bit 17
    once the reference is set."""

    code = HOMING_MANUFACTURER

    def __init__(self) -> None:
        self.running = False

    def enter(self, ax: ModeAxis) -> None:
        self.running = False

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        if not _rising(prev, cw, CW_OMS_4):
            return
        star.homed = False  # the reference is set again at the end: bit 17 rises then [6.1.4]
        kind = ax.param(0x2024, 1, default=0)
        offset = star.user_to_counts(ax.param(0x2024, 6, default=0))
        if kind == 0:
            ax.shift_position(offset - ax.p)
            self._done(star)
        elif kind == 6:
            ax.shift_position(offset - ax.dp)
            self._done(star)
        else:
            self.running = star.task_active = True

    def _done(self, ax: StarAxis) -> None:
        self.running = ax.task_active = False
        ax.homed = True

    def step(self, ax: ModeAxis, dt: float) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        if not self.running:
            ax.dp, ax.dv = stop_step(ax.dp, ax.dv, ax.profile_deceleration(), dt)
            return
        speed = min(abs(star.user_to_counts(ax.param(0x2024, 3, default=0))) or star.vlim() / 10, star.vlim())
        acc = star.ramp(ax.param(0x2024, 4, default=10), speed)
        dec = star.ramp(ax.param(0x2024, 5, default=10), speed)
        ax.dp, ax.dv, arrived = position_step(ax.dp, ax.dv, ax.switch_position, speed, acc, dec, dt)
        if arrived:
            ax.shift_position(star.user_to_counts(ax.param(0x2024, 6, default=0)) - ax.switch_position)
            self._done(star)

    def status_bits(self, ax: ModeAxis) -> int:
        return SW_TARGET_REACHED if not self.running and ax.standstill() else 0


class MotionTask(OpMode):
    """0xFF: the direct motion task 0 (0x2022 subs 1-3, 6, 7, 13, 14): started by writing the task
    number 0x2022:05 = 0 (SDO or RPDO 35) or by RPDO 34; type bit 0 = relative (to the last target,
    or the actual position when not in position); speed 0x2022:02 x VMUL (0x2022:0D), or 0x2022:0E
    when 0, in increments (2^20) per 250 us; ramps 0x2022:06 / :07 in ms to that speed. Statusword
    bit 8 toggles when a task is completed, bit 10 at the target, 0x1002 bit 16 while it runs."""

    code = POSITION

    def __init__(self) -> None:
        self.target: float | None = None
        self.speed = self.acc = self.dec = 1.0

    def enter(self, ax: ModeAxis) -> None:
        self.target = None

    def start(self, ax: StarAxis) -> None:
        p = ax.param
        position = float(p(0x2022, 1, default=0))
        kind = p(0x2022, 3, default=0)
        if kind & 1:
            base = self.target if self.target is not None else ax.dp
            position += base
        speed = abs(p(0x2022, 2, default=0)) * p(0x2022, 13, default=1) or abs(p(0x2022, 14, default=0))
        self.speed = min(max(speed * 4000.0, 1.0), ax.vlim())
        self.acc = ax.ramp(p(0x2022, 6, default=10), self.speed)
        self.dec = ax.ramp(p(0x2022, 7, default=10), self.speed)
        self.target = position
        ax.task_active = True

    def step(self, ax: ModeAxis, dt: float) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        if self.target is None or not star.task_active:
            ax.dp, ax.dv = stop_step(ax.dp, ax.dv, ax.profile_deceleration(), dt)
            return
        ax.dp, ax.dv, arrived = position_step(ax.dp, ax.dv, self.target, self.speed, self.acc, self.dec, dt)
        if arrived:
            star.task_active = False
            star.toggle = not star.toggle

    def status_bits(self, ax: ModeAxis) -> int:
        star: StarAxis = ax  # type: ignore[assignment]
        return SW_TARGET_REACHED if not star.task_active and ax.standstill() else 0


class StarProfilePosition(ProfilePosition):
    """pp with the SERVOSTAR's statusword bit 8 toggling at every target reached and 0x1002
    bit 16 (motion task active) from the acknowledged set-point to its target: the status
    byte 2080h:09 reads 03h (task active, reference set) while it runs, 0Ah (reference set,
    in position) at the target [9.6 step 10]."""

    def __init__(self) -> None:
        super().__init__()
        self._was_arrived = True

    def enter(self, ax: ModeAxis) -> None:
        super().enter(ax)
        self._was_arrived = True

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        super().on_controlword(ax, prev, cw)
        star: StarAxis = ax  # type: ignore[assignment]
        star.task_active = not self.arrived or self.pending is not None

    def post_step(self, ax: ModeAxis, dt: float) -> None:
        super().post_step(ax, dt)
        star: StarAxis = ax  # type: ignore[assignment]
        if self.arrived and not self._was_arrived:
            star.toggle = not star.toggle
        self._was_arrived = self.arrived
        star.task_active = not self.arrived or self.pending is not None


class StarHoming(Homing):
    """hm (6), the CiA 402 homing, with the SERVOSTAR's status register: 0x1002 bit 16 (motion
    task active) while it runs, bit 17 (reference set) cleared at its start and set once the
    home offset is set; at the end the status byte 2080h:09 has bit 0 = 0, bit 1 = 1, bit 3 =
    1 (homing finished, reference set, in position) [9.6 step 7]."""

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        star: StarAxis = ax  # type: ignore[assignment]
        if _rising(prev, cw, CW_OMS_4):
            star.homed = False
            self.phase = 'idle'
        self._run(star, lambda: super(StarHoming, self).on_controlword(ax, prev, cw))

    def resume(self, ax: ModeAxis) -> None:
        self._run(ax, lambda: super(StarHoming, self).resume(ax))  # type: ignore[arg-type]

    def step(self, ax: ModeAxis, dt: float) -> None:
        self._run(ax, lambda: super(StarHoming, self).step(ax, dt))  # type: ignore[arg-type]

    def _run(self, star: StarAxis, action: Callable[[], None]) -> None:
        before = self.phase
        action()
        star.task_active = self.phase in ('search', 'creep')
        if self.phase == 'done' and before != 'done':
            star.homed = True


# the SERVOSTAR's own classes by mode number (the others: the CiA 402 models of opmodes)
STAR_MODES: dict[int, type[OpMode]] = {
    TRAJECTORY: Trajectory, SPEED_DIGITAL: DigitalSpeed, CURRENT_DIGITAL: DigitalCurrent, JOG: Jog,
    HOMING_MANUFACTURER: ManufacturerHoming, POSITION: MotionTask, PROFILE_POSITION: StarProfilePosition,
    HOMING: StarHoming}
