"""The references of an OPEN drive axis (shared/drives/opendrive.md §4.3, §5): the speed
reference (0x201A or 0x201D) in pv, the torque reference 0x201C in pt, from direct commands and
velocity streams, with the command dead-man, the bridge's position loop and the cycle's last
check; what a command or trajectory must be to be taken. The RUN logic that decides whether
they reach the motor is :class:`~drive_bridge.families.opendrive.driver.RunLogicDriver`'s.
"""
from __future__ import annotations

import math
import time

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.modes import Mode, mode_name
from drive_bridge.families.opendrive import objects as od
from drive_bridge.families.opendrive.errors import RunLogicError
from drive_bridge.families.opendrive.feedback import PositionFeedback
from drive_bridge.families.opendrive.options import DriveOptions
from drive_bridge.families.opendrive.units import Units
from drive_bridge.joint import BufferFeeder, DriveState, NodeIo, Setpoint, SetpointSource
from drive_bridge.joint.driverbase import JointDriverBase
from drive_bridge.joint.position_loop import PositionLoop
from drive_bridge.joint.strategy import StreamStrategy
from drive_bridge.model import AxisConfig, Timeouts

PV = int(Mode.PROFILE_VELOCITY)
PT = int(Mode.PROFILE_TORQUE)
MODES = (PV, PT)
Key = tuple[int, int]


class References(JointDriverBase):
    """The reference half of the OPEN drive's joint driver (state guarded by the lock)."""

    error = RunLogicError
    liveness = 'node guarding'

    def __init__(self, node: NodeIo, config: AxisConfig, timeouts: Timeouts, cycle_period: float,
                 family: str) -> None:
        super().__init__(node, config, timeouts, cycle_period)
        self.family = family
        self.options = DriveOptions.of(config.drive)
        self.units = Units(self.options)
        offset = self.options.array_offset
        self.key: dict[str, Key] = {
            'logic': (od.INPUTS_STANDARD_WR, 0), 'run': (od.INPUTS_STANDARD_RD, 0), 'alarms': (od.ALARMS, 0),
            'speed': (self.options.speed_reference, 0), 'torque_reference': (od.TORQUE_REFERENCE, 0),
            'velocity': self.options.actual_velocity.key(offset),
        }
        if self.options.actual_torque is not None:
            self.key['torque'] = self.options.actual_torque.key(offset)
        if self.options.position is not None:
            self.key['position'] = self.options.position.key(offset)
        self.feedback_position = PositionFeedback(node, self.units, self.key['velocity'], self.key.get('position'))
        self._mode = config.mode if config.mode in MODES else PV
        self._speed = 0  # raw references while commanded
        self._torque = 0
        self._refused = ''  # why the cycle check last refused a reference
        if config.position_loop.enabled:
            self.loop = PositionLoop(config.position_loop, config.limits)

    def placement(self) -> str:
        return f'family {self.family!r}'

    # provided by the RUN logic
    @property
    def drive_state(self) -> DriveState:
        raise NotImplementedError

    def fault_description(self) -> str:
        raise NotImplementedError

    def _run_off(self) -> None:
        """RUN low: the cycle's own stop (a refused reference, limits.on_violation: quick_stop)."""
        raise NotImplementedError

    def _read(self, name: str) -> int | None:
        value = self.node.read(*self.key[name])
        return None if value is None else int(value)

    def _position(self) -> float:
        return self.feedback_position.position()

    # -- each cycle (under the lock) --------------------------------------------------------------
    def _check_references(self, now: float) -> None:
        """The last check of this cycle's reference (``joint.setpoint_guard``): beyond the
        joint's limits, or (streamed through the bridge's loop) changed faster than they allow,
        it is never written; the axis is halted (references 0, RUN kept) or, with
        ``limits.on_violation: quick_stop``, stopped (RUN low), and the cause reported."""
        limits, units = self.config.limits, self.units
        streamed = self.intents.source is not None and self._looped()
        if self._mode == PV:
            problem = self.guard.check(limits, 'velocity', self._speed * units.reference_per_unit, now,
                                       abs(units.reference_per_unit), streamed)
        else:
            problem = self.guard.check(limits, 'effort', self._torque * units.torque_per_unit, now,
                                       abs(units.torque_per_unit), False)
        if problem is None:
            return
        self._clear_commands()
        quick_stop = self.config.limits.on_violation == 'quick_stop'
        if quick_stop:
            self._run_off()
        else:
            self.halted = True
        self._refused = (f'set-point refused before it was written: {problem}; axis held '
                         f'({"RUN low" if quick_stop else "references 0, RUN kept"}, limits.on_violation)')
        self.message = self._refused
        self.node.report_setpoint_refused(self.joint, f'{self.where()}: {self._refused}')

    def _clear_commands(self) -> None:
        """References 0, no stream, no dead-man running."""
        self._speed = self._torque = 0
        self.intents.drop()
        self.deadman.clear()

    def _follow(self, now: float) -> None:
        """The stream's set-point, then the dead-man, then the position loop."""
        if self.intents.source is not None:
            setpoint = self.intents.source(now)
            if setpoint is not None:
                self._apply(setpoint, saturate=True)
        timeout = self.timeouts.command_timeout
        if self.deadman.expired(timeout):
            self._speed = self._torque = 0
            self.intents.loop_target = None
            reference = f'0x{self.options.speed_reference:04X}' if self._mode == PV else '0x201C'
            self.message = (f'no command for {timeout * 1000:.0f} ms in {mode_name(self._mode)}: '
                            f'references 0 ({reference} = 0)')
        if self.intents.loop_target is not None and self._looped():
            measured = self._position()
            velocity = None if math.isnan(measured) else self.loop_velocity(measured, 'references 0, RUN kept')
            self._speed = 0 if velocity is None else self.units.speed_raw_saturated(velocity)

    def _looped(self) -> bool:
        return self.loop is not None and self._mode == PV

    def _apply(self, setpoint: Setpoint, saturate: bool) -> None:
        if setpoint.position is not None and self._looped():
            velocity = self._read('velocity')
            start = self.units.velocity_si(velocity) if velocity is not None else 0.0
            self.follow_position(setpoint.position, setpoint.velocity, start)
            return
        if setpoint.velocity is not None and self._mode == PV:
            self.intents.loop_target = None
            self._speed = (self.units.speed_raw_saturated(setpoint.velocity) if saturate
                           else self.units.speed_raw(setpoint.velocity) or 0)
        if setpoint.effort is not None and self._mode == PT:
            self._torque = (self.units.torque_raw_saturated(setpoint.effort) if saturate
                            else self.units.torque_raw(setpoint.effort) or 0)
        self.deadman.fed()

    # -- commands -----------------------------------------------------------------------------------
    def check_command(self, position: float | None = None, velocity: float | None = None,
                      effort: float | None = None) -> None:
        """Raise if the command cannot be applied now: position commands (none on this family),
        the wrong field for the mode, limits, the drive's INT16 range, state."""
        where = self.where()
        if position is not None and not self._looped():
            loop = ' (or set the axis\' position_loop to close a position loop in the bridge)' \
                if self.loop is None else ' (the axis\' position loop works in pv)'
            raise RunLogicError(f'{where}: family {self.family!r} takes no position commands (no position '
                                f'reference on the drive); command velocity in pv or effort in pt{loop}')
        self.check_limits(position, velocity, effort)
        units, options = self.units, self.options
        for value, (kind, mode, raw, span, reference) in (
                (velocity, ('a velocity', PV, units.speed_raw, units.velocity_range,
                            f'0x{options.speed_reference:04X} is INT16, 16384 = n_MAX {options.n_max_rpm:g} rpm')),
                (effort, ('an effort', PT, units.torque_raw, units.effort_range,
                          f'0x201C is INT16, 4095 = T_nom {options.rated_torque:g} N·m'))):
            if value is None:
                continue
            if self._mode != mode:
                raise RunLogicError(f'{where}: {kind} command needs {mode_name(mode)}; mode is {mode_name(self._mode)}')
            if raw(value) is None:
                low, high = span()
                raise RunLogicError(f'{where}: {kind.split()[1]} {value:.6g} is beyond the drive\'s range '
                                    f'{low:.6g}..{high:.6g} ({reference}): refused, not wrapped')
        self.require_alive()
        if self.drive_state is DriveState.FAULT:
            raise RunLogicError(f'{where}: {self.fault_description()}')
        if self.drive_state is not DriveState.ENABLED:
            raise RunLogicError(f'{where}: {self.state_text()}, not enabled; enable it first (~/enable)')
        if self.halted:
            raise RunLogicError(f'{where}: halted (references 0); resume first')

    def command(self, position: float | None = None, velocity: float | None = None,
                effort: float | None = None) -> None:
        """Set the reference (non-blocking; sent on the next cycle); feeds the dead-man."""
        self.check_command(position, velocity, effort)
        with self.lock:
            self.intents.source = None
            self._apply(Setpoint(position=position, velocity=velocity, effort=effort), saturate=False)

    def wait_target_reached(self, timeout: float) -> None:
        raise RunLogicError(f'{self.where()}: family {self.family!r} has no position target to reach')

    def command_field(self) -> str | None:
        return 'velocity' if self._mode == PV else 'effort'

    # -- streaming ----------------------------------------------------------------------------------
    def stream_strategy(self) -> StreamStrategy | None:
        """Velocity set-points every cycle in pv (through the bridge's position loop when the axis
        sets one); no trajectory in pt."""
        if self._mode != PV:
            return None
        return StreamStrategy.POSITION_LOOP if self._looped() else StreamStrategy.CYCLIC_VELOCITY

    def check_trajectory(self, has_positions: bool, has_velocities: bool) -> None:
        """In pv a trajectory is followed through its velocities (open loop: the drive has no
        position reference), so it must carry them unless the bridge's position loop runs on a
        configured position quantity; pt takes none."""
        if self._mode != PV:
            raise RunLogicError(f'{self.where()}: a trajectory needs pv (velocity references); mode is '
                                f'{mode_name(self._mode)}')
        if not has_velocities and not self._looped():
            raise RunLogicError(f'{self.where()}: family {self.family!r} has no position reference: a trajectory '
                                'of positions only is refused; give velocities (followed open loop), or configure '
                                'a position quantity and position_loop')

    def commanded_position(self) -> float:
        target = self.intents.loop_target
        return target[0] if target is not None and self._looped() else self._position()

    def stop_deceleration(self) -> float:
        """The joint's max_acceleration, else full speed n_MAX to rest in one second."""
        value = self.config.limits.max_acceleration
        return value if value else abs(self.units.n_max * self.units.joint_per_motor)

    def set_setpoint_source(self, source: SetpointSource | None) -> None:
        with self.lock:
            self.intents.source = source
            if source is None and self.deadman.last:
                self.deadman.last = time.monotonic()  # the dead-man then stops if nothing follows

    def set_buffer_feeder(self, feeder: BufferFeeder | None) -> None:
        if feeder is not None:
            raise RunLogicError(f'{self.where()}: family {self.family!r} has no interpolation buffer (PVT)')

    def interpolation_free_slots(self) -> int | None:
        return None

    def pvt_time_unit(self) -> float | None:
        return None

    def push_interpolation_point(self, position: int, time_units: int, velocity: int) -> None:
        raise RunLogicError(f'{self.where()}: family {self.family!r} has no interpolation buffer (PVT)')

    def is_stream_fault(self, event: EmcyEvent) -> bool:
        return False
