"""The control function of a simulated CiA 402 axis, one model step at a time: the demand (the
mode's or a stop ramp's) within the software position limits 0x607D, the actual values
following it (lag, inertia, friction, the torque limit), the motor torque, and the following
error monitoring.

Following error (0x6065/0x6066) is monitored in PP, HM, IP and CSP, in Operation Enabled and
Quick Stop Active; window 0xFFFFFFFF switches it off.
"""
from __future__ import annotations

from typing import Protocol

from drive_bridge.cia402.statemachine import State
from drive_bridge.sim.devicecontrol import ENERGISED, ControlledAxis, DeviceControl
from drive_bridge.sim.motion import clamp, lag_follow, max_acceleration, motor_torque, stop_step, torque_drive

EMCY_FOLLOWING_ERROR = 0x8611
STANDSTILL = 1.0  # counts/s: below this the axis counts as stopped
STOP_SETTLE_MAX = 0.2  # s: a stop ramp ends at the latest this long after the demand reached 0


class LoopAxis(ControlledAxis, Protocol):
    """The axis as its control function sees it: the plant's constants, limits and faults."""

    control: DeviceControl
    lag: float
    inertia: float
    friction: float

    def software_limits(self) -> tuple[float, float] | None: ...

    def fault(self, code: int, manufacturer: bytes = b'', persistent: bool = False, emit: bool = True) -> None: ...


class ControlLoop:
    """Steps one axis; ``fe_time`` is how long the following error has been outside its window."""

    def __init__(self, axis: LoopAxis) -> None:
        self._axis = axis
        self.fe_time = 0.0
        self._stepping = False
        self._step_shift = 0.0

    def shifted(self, delta: float) -> None:
        """The axis' positions moved by ``delta`` (homing): a running step's start demand moves along."""
        if self._stepping:
            self._step_shift += delta

    def step(self, dt: float) -> None:
        """Step demand and plant over ``dt`` s; then limits, following error, stop ramps."""
        ax = self._axis
        d0, v0 = ax.dp, ax.v
        state = ax.state
        mode = ax.mode_impl
        stop = ax.control.stop
        torque_driven = False
        if stop is not None:
            ax.dp, ax.dv = stop_step(ax.dp, ax.dv, stop.deceleration, dt)
        elif state is State.OPERATION_ENABLED:
            self._stepping, self._step_shift = True, 0.0
            mode.step(ax, dt)
            self._stepping = False
            d0 += self._step_shift
            torque_driven = mode.torque_controlled
        limits = ax.software_limits()
        if limits is not None and not torque_driven and (ax.dp <= limits[0] and ax.dv <= 0
                                                         or ax.dp >= limits[1] and ax.dv >= 0):
            ax.dp, ax.dv = clamp(ax.dp, *limits), 0.0
        v_max = ax.motion_parameters()['motor_speed']
        if state in ENERGISED and torque_driven:
            limit = ax.torque_limit()
            ax.dtorque = clamp(ax.dtorque, -limit, limit)
            ax.p, ax.v = torque_drive(ax.p, ax.v, ax.dtorque, dt, ax.inertia, ax.friction, v_max)
            ax.dp, ax.dv = ax.p, ax.v
        elif state in ENERGISED:
            a_max = max_acceleration(ax.torque_limit(), ax.v, ax.inertia, ax.friction)
            ax.p, ax.v = lag_follow(ax.p, ax.v, d0, ax.dp, dt, ax.lag, v_max, a_max)
        else:
            ax.p, ax.v = torque_drive(ax.p, ax.v, 0.0, dt, ax.inertia, ax.friction, v_max)
            ax.dp, ax.dv = ax.p, ax.v
        limit = ax.torque_limit()
        ax.torque = clamp(motor_torque((ax.v - v0) / dt, ax.v, ax.inertia, ax.friction), -limit, limit)
        if state is State.OPERATION_ENABLED and ax.control.stop is None:
            mode.post_step(ax, dt)
        self._check_following_error(dt)
        ax.control.settle(dt, STANDSTILL, STOP_SETTLE_MAX)

    def _check_following_error(self, dt: float) -> None:
        ax = self._axis
        if ax.state not in (State.OPERATION_ENABLED, State.QUICK_STOP_ACTIVE) or not ax.mode_impl.position_controlled:
            self.fe_time = 0.0
            return
        parameters = ax.motion_parameters()
        window = parameters['fe_window']
        if window == 0xFFFFFFFF or abs(ax.dp - ax.p) <= window:
            self.fe_time = 0.0
            ax.fe_active = False
            return
        self.fe_time += dt
        if self.fe_time > parameters['fe_timeout']:
            ax.fe_active = True
            ax.fault(EMCY_FOLLOWING_ERROR)
