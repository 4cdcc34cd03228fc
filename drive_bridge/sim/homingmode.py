"""The CiA 402 homing mode (hm) of a simulated axis: the home switch search, the creep onto
it and the methods that home where the axis stands."""
from __future__ import annotations

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import CW_OMS_4, SW_OMS_12, SW_OMS_13, SW_TARGET_REACHED
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.motion import position_step, stop_step, velocity_step
from drive_bridge.sim.opmode import OpMode, falling, rising

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
        if rising(prev, cw, CW_OMS_4):
            self._start(ax)
        elif falling(prev, cw, CW_OMS_4) and self.phase in ('search', 'creep'):
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
