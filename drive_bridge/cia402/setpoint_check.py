"""The CiA 402 axis' last check of its commanded targets each cycle (``joint.setpoint_guard``),
in device units as they are about to be written: which targets a mode carries, which of them
change under the bridge's control each cycle (cyclic modes, linear IP, the position loop) and
which only name a goal the drive ramps to itself (pp, pv, pt, homing); what a refusal does
(:class:`SetpointChecks`, a mixin of the axis), also for PVT points and direct commands."""
from __future__ import annotations

from collections.abc import Mapping

from drive_bridge.cia402.errors import AxisError, SetpointRefused
from drive_bridge.cia402.modes import CYCLIC_MODES, VELOCITY_MODES, Mode
from drive_bridge.cia402.profile import PvtRecord
from drive_bridge.joint.driverbase import JointDriverBase
from drive_bridge.joint.setpoint_guard import SetpointGuard
from drive_bridge.model import AxisConfig

KIND = {'target_position': 'position', 'target_velocity': 'velocity', 'target_torque': 'effort'}


def cyclic(mode: int, looped: bool) -> bool:
    """The bridge makes this mode's motion set-point by set-point (its change is checked)."""
    return mode in CYCLIC_MODES or mode == Mode.INTERPOLATED_POSITION or looped


def check_targets(guard: SetpointGuard, config: AxisConfig, mode: int, looped: bool,
                  targets: Mapping[str, int], ip_point: int | None, now: float) -> str | None:
    """The first problem of this cycle's commanded targets (None: they may go out)."""
    scaling, limits = config.scaling, config.limits
    rate = cyclic(mode, looped)
    values: list[tuple[str, float, float]] = []
    if ip_point is not None and mode == Mode.INTERPOLATED_POSITION:
        values.append(('position', scaling.position_to_si(ip_point), abs(scaling.position_factor)))
    for name, raw in targets.items():
        kind = KIND.get(name)
        if kind is None or (kind == 'position' and mode == Mode.INTERPOLATED_POSITION):
            continue
        if kind == 'position':
            values.append((kind, scaling.position_to_si(raw), abs(scaling.position_factor)))
        elif kind == 'velocity':
            values.append((kind, scaling.velocity_to_si(raw), abs(scaling.velocity_factor)))
        else:
            values.append((kind, scaling.effort_to_si(raw), abs(scaling.effort_factor)))
    for kind, value, resolution in values:
        problem = guard.check(limits, kind, value, now, resolution, rate)
        if problem is not None:
            return problem
    return None


def seed_hold(guard: SetpointGuard, config: AxisConfig, targets: Mapping[str, int], now: float) -> None:
    """Targets written without the check (holding the measured position, zeros while idle)."""
    scaling = config.scaling
    position = targets.get('target_position')
    guard.seed('position', scaling.position_to_si(position) if position is not None else None, now)
    velocity = targets.get('target_velocity')
    guard.seed('velocity', scaling.velocity_to_si(velocity) if velocity is not None else None, now)


class SetpointChecks(JointDriverBase):
    """The refusals of the axis' set-point checks (state shared with the CiA 402 axis)."""

    error = AxisError
    pvt: PvtRecord | None
    _mode: int
    _pvt_guard: SetpointGuard  # the same for PVT points, on the points' own time line
    _pvt_clock: float  # s: the sum of the pushed points' times
    _setpoint_refused: str  # why the last set-point was refused ('' since the axis was enabled again)

    def read(self, name: str) -> int | float | None:
        raise NotImplementedError

    def _looped(self) -> bool:
        raise NotImplementedError

    def _quick_stop_from_cycle(self) -> None:
        raise NotImplementedError

    def way_out(self) -> str:
        raise NotImplementedError

    def _refuse_setpoint(self, problem: str, actual: int | float | None) -> None:
        """A set-point beyond the limits is never written: the stream or command is dropped,
        the targets hold the last good position (else the measured one), the axis is held
        (HALT or quick stop, ``limits.on_violation``) and the cause reported once."""
        last = self.guard.last.get('position')
        scaling = self.config.scaling
        hold = scaling.position_to_device(last[0]) if last is not None else actual
        self.intents.drop()
        self.intents.targets = {'target_velocity': 0, 'target_torque': 0}
        if hold is not None:
            self.intents.targets['target_position'] = int(hold)
        reaction = self.config.limits.on_violation
        if reaction == 'quick_stop':
            self._quick_stop_from_cycle()
        else:
            self.halted = True
        self._setpoint_refused = (f'set-point refused before it was written: {problem}; axis held '
                                  f'({"quick stop" if reaction == "quick_stop" else "HALT"}, limits.on_violation)')
        self.message = self._setpoint_refused
        self.node.report_setpoint_refused(self.config.joint, f'{self.where()}: {self._setpoint_refused}')

    def _check_step(self, position: float | None, velocity: float | None) -> None:
        """A direct command the cycle check would refuse is refused here, before it is applied:
        the axis is held since a refused set-point, or the command is a step larger than one
        cycle allows in a mode the bridge feeds set-point by set-point."""
        if self._setpoint_refused:
            raise SetpointRefused(f'{self.where()}: held since a set-point was refused ({self._setpoint_refused}); '
                            'resume it (~/resume) or enable it again before commanding it')
        looped = self._looped()
        if looped or not cyclic(self._mode, looped):
            return
        scaling = self.config.scaling
        problem = None
        if position is not None:
            problem = self.guard.step_problem(self.config.limits, 'position', position, abs(scaling.position_factor))
        elif velocity is not None and self._mode in VELOCITY_MODES:
            problem = self.guard.step_problem(self.config.limits, 'velocity', velocity, abs(scaling.velocity_factor))
        if problem is not None:
            raise SetpointRefused(f'{self.where()}: {problem}')

    def _pvt_point_allowed(self, position: int, time_units: int, velocity: int) -> bool:
        """The cycle check for a PVT point (the drive interpolates between points): its position
        and velocity within the limits, its position change within max_velocity over the point's
        time (the first point of a motion: the planner checked its lead-in from the current
        state; the time-0 point that ends a motion is no move). A refused point is not pushed: the
        stream stops and the axis is held."""
        assert self.pvt is not None
        scaling = self.config.scaling
        self._pvt_clock += time_units * self.pvt.time_unit
        position_si, velocity_si = scaling.position_to_si(position), scaling.velocity_to_si(velocity)
        problem = (self._pvt_guard.check(self.config.limits, 'position', position_si, self._pvt_clock,
                                         abs(scaling.position_factor), rate=time_units > 0)
                   or self._pvt_guard.check(self.config.limits, 'velocity', velocity_si, self._pvt_clock,
                                            abs(scaling.velocity_factor), rate=False))
        if time_units == 0:  # the end of a motion: the next one is measured from where the drive is then
            self._pvt_guard.forget()
        if problem is None:
            return True
        with self.lock:
            self.intents.feeder = None
            self._refuse_setpoint(f'PVT point: {problem}', self.read('position'))
        return False
