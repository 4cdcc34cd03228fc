"""The synchronous modes of a simulated CiA 402 axis: interpolated position (ip, over its
buffer) and cyclic synchronous position, velocity and torque (csp, csv, cst), each set-point
interpolated over one period from the SYNC that latched it."""
from __future__ import annotations

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import CW_OMS_4, SW_OMS_12, SW_OMS_13, SW_TARGET_REACHED
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.motion import Segment, clamp
from drive_bridge.sim.opmode import OpMode


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
