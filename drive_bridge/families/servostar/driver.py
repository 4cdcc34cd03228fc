"""The joint driver of a SERVOSTAR: the CiA 402 axis with what the SERVOSTAR does differently
(shared/drives/servostar-400-600.md §3, §4, §5).

- **No Fault state.** The statusword never shows the Fault pattern: a fault is bit 31 of the
  status register 0x1002 (TPDO 1) or an EMCY of category 1, 2 or 4 whose follow-up (code 0x0000)
  still reports a pending error register. The axis then reports the device state FAULT (and so
  the drive-independent state ``fault``), refuses to enable, and :meth:`reset_fault` clears it
  the way its category says: category 2 (following error 0x8611, response monitoring 0x8181,
  ...) by a rising edge of controlword bit 11; category 1 and 4 (and a pending error whose EMCY
  the bridge did not see) by bit 7, after which the drive restarts: the reset waits until the
  master found the restarted drive and configured it again.
- **Trajectory mode 0xFA (-6).** One absolute position setpoint 0x2022:04 per SYNC (the
  family's streaming strategy StreamStrategy.CYCLIC); its RPDO goes out every cycle, so the stream never
  pauses while the mode is active: idle and enabled, the axis holds the last setpoint (the
  actual position when it was enabled). A step between two setpoints of VLIM x period or
  more is never sent: a direct position command that would make one is refused, a trajectory
  stream that would make one is aborted and the axis held (HALT, ``~/resume`` releases it).
  The mode is refused while PTBASE differs from the SYNC period.
- **Modes** change only at standstill (refused while the motor turns); 0x6060 is write-only,
  a mode counts once 0x6061 shows it; the family's names ``trajectory``/``fa``,
  ``position``/``ff``, ``speed_digital``/``fe``, ``current_digital``/``fd`` are taken besides the
  numbers and the CiA 402 names.
- **Units** from the boot (PRBASE, VLIM, 0x6093; :mod:`~drive_bridge.families.servostar.units`):
  profile position 0x607A in user units, profile velocity 0x60FF in increments per 250 us;
  the joint's ``max_velocity`` is VLIM at the joint unless the config gives a lower one.
- **Stop deceleration** without a ``max_acceleration`` limit: VLIM over the drive's ramp DEC.
"""
from __future__ import annotations

import logging
import time
from dataclasses import replace

from drive_bridge.cia402 import statemachine as sm
from drive_bridge.cia402.axis import HOLD_COMMAND, Axis
from drive_bridge.cia402.errors import AxisError
from drive_bridge.cia402.modes import mode_name, parse_mode
from drive_bridge.cia402.profile import Cia402Profile, FaultModel
from drive_bridge.cia402.statemachine import State
from drive_bridge.families.servostar import emcy, objects as o
from drive_bridge.families.servostar.options import AxisOptions
from drive_bridge.families.servostar.units import DriveUnits
from drive_bridge.joint import AxisSnapshot, NodeIo, Setpoint
from drive_bridge.model import AxisConfig, Timeouts

log = logging.getLogger('drive_bridge.families.servostar')
STANDSTILL_RPM = 1.0  # |speed| below this is standstill for a mode change
MODE_LABELS = {o.MODE_TRAJECTORY: 'trajectory (0xFA)', o.MODE_POSITION: 'position (0xFF)',
               o.MODE_SPEED_DIGITAL: 'speed digital (0xFE)', o.MODE_CURRENT_DIGITAL: 'current digital (0xFD)'}


def mode_label(code: int) -> str:
    return MODE_LABELS.get(code, mode_name(code))


def parse_family_mode(mode: int | str) -> int:
    """A mode by number, CiA 402 name or the family's own name (``trajectory``, ``fa``, ...)."""
    if isinstance(mode, str) and mode.strip().lower() in o.MODE_NAMES:
        return o.MODE_NAMES[mode.strip().lower()]
    return parse_mode(mode)


class ServostarAxis(Axis):
    """The one axis of a SERVOSTAR node."""

    def __init__(self, node: NodeIo, config: AxisConfig, timeouts: Timeouts, cycle_period: float,
                 profile: Cia402Profile) -> None:
        super().__init__(node, config, timeouts, cycle_period, profile=profile)
        self.options = AxisOptions.of(config.drive)
        self.units: DriveUnits | None = None
        self.ptbase_period: float | None = None  # s, PTBASE as read at boot
        self.key.update(status_register=(o.STATUS_REGISTER, 0), pp_target=o.TARGET_POSITION_PP)
        self._configured_limit = config.limits.max_velocity
        self._node_resets = 0
        self._reset_stamp = 0.0
        self._hold: int | None = None  # mode 0xFA, enabled and idle: the setpoint held
        self._device_state = State.UNKNOWN  # as the statusword shows it (no Fault pattern ever)
        self._last_sent: int | None = None  # the last trajectory setpoint, in device units (2^20 / rev)
        self._emcy_marker: tuple[int, int] = (0, 0)
        self._emcy_faults: dict[int, int] = {}  # code -> category, pending by the EMCY state machine

    # -- boot ---------------------------------------------------------------------------------------
    def apply_units(self, units: DriveUnits, ptbase_period: float | None) -> None:
        """The drive's units and limits as read at boot: SI scaling, max_velocity = VLIM at the joint
        unless the config gives less (the caller checked that it does not give more)."""
        scaling = units.scaling(self.options, self.config.joint_type)
        vlim = units.joint_speed_limit(self.options, self.config.joint_type)
        limit = self._configured_limit if vlim is None or (
            self._configured_limit is not None and self._configured_limit <= vlim) else vlim
        with self._cond:
            self.units = units
            self.ptbase_period = ptbase_period
            self.config = replace(self.config, scaling=scaling, limits=replace(self.config.limits, max_velocity=limit))
            self._stop_deceleration = None

    def on_node_reset(self) -> None:
        super().on_node_reset()
        with self._cond:
            self._node_resets += 1
            self._reset_stamp = time.time()
            self._hold = None

    # -- faults -------------------------------------------------------------------------------------
    def _pending_emcy_faults(self) -> dict[int, int]:
        """code -> category of the faults the EMCYs report pending (the drive's error state
        machine: a fault EMCY, then code 0x0000 frames whose register is what is left)."""
        history = self.node.emcy_history()
        marker = (len(history), id(history[-1]) if history else 0)
        if marker != self._emcy_marker:
            faults: dict[int, int] = {}
            for event in history:
                if emcy.is_follow_up(event):
                    if not event.register:
                        faults.clear()
                    continue
                category = emcy.category(event)
                if category in emcy.FAULT_CATEGORIES or category == 0:
                    faults[event.code] = category
            self._emcy_faults, self._emcy_marker = faults, marker
        return self._emcy_faults

    def _register_fault(self) -> bool:
        register = self.node.read(*self.key['status_register'])
        return register is not None and bool(int(register) & o.DRVSTAT_ERROR_PENDING)

    def fault_pending(self) -> bool:
        """The drive reports a fault (0x1002 bit 31, or a fault EMCY still pending)."""
        return self._register_fault() or bool(self._pending_emcy_faults())

    def _state_of(self, statusword: int) -> State:
        state = super()._state_of(statusword)
        self._device_state = state
        return State.FAULT if self.fault_pending() else state

    def _device_command(self, state: State) -> int:
        """In a fault the drive reacts by itself: category 2 brakes on the emergency ramp with the
        output stage on (the controlword keeps the state the statusword shows: never "disable
        voltage" under a braking drive), categories 1 and 4 switch the stage off (disable
        voltage, so no enable command reaches it); plus the reset bit's edge while a reset runs."""
        if state is not State.FAULT:
            return super()._device_command(state)
        if self._fault_categories() - {2}:  # the drive switched its output stage off
            hold = sm.CMD_DISABLE_VOLTAGE
        else:  # category 2: it brakes on the emergency ramp, its stage on
            hold = HOLD_COMMAND.get(self._device_state, sm.CMD_DISABLE_VOLTAGE)
        if self._fault_reset_phase == 1:
            self._fault_reset_phase = 2
            return hold  # the reset bit low: its rising edge comes next
        if self._fault_reset_phase == 2:
            return hold | 1 << self.fault_model.reset_bit
        return hold

    def _fault_categories(self) -> set[int]:
        categories = set(self._pending_emcy_faults().values())
        if self._register_fault() and not categories:
            categories.add(0)  # pending without an EMCY the bridge saw: the reset restarts the drive
        return categories

    def reset_fault(self, timeout: float | None = None) -> None:
        """Category 2 by the rising edge of bit 11; categories 1 and 4 (or unknown) by bit 7,
        after which the drive restarts and is configured again by the master (waited for)."""
        self._require_available()
        if self.state is not State.FAULT:
            return
        categories = self._fault_categories()
        restart = bool(categories - {2})
        self.fault_model = FaultModel(fault_state=False, reset_bit=o.CW_RESET_FAULT if restart else o.CW_ACKNOWLEDGE)
        if not restart:
            super().reset_fault(timeout)
            with self._cond:
                self._message = 'fault acknowledged (controlword bit 11)'
            return
        resets = self._node_resets
        with self._cond:
            self._target_state = State.SWITCH_ON_DISABLED
            self._fault_reset_phase = 1
        wait = timeout if timeout is not None else max(5.0, 3 * self.timeouts.boot + self.timeouts.state_switch)

        def back() -> bool:
            return (self._node_resets > resets and self.node.available
                    and self.node.stamp(*self.key['statusword']) > self._reset_stamp and not self.fault_pending())
        try:
            self._wait(back, wait, 'fault reset (controlword bit 7: the drive restarts and is configured again)')
        except AxisError as exc:
            with self._cond:
                self._fault_reset_phase = 0
            restarted = 'it restarted, but the fault is still present' if self._node_resets > resets else \
                'it did not restart'
            raise AxisError(f'{exc}; {restarted}{self._fault_text()}') from None
        self._reset_emcy_count = len(self.node.emcy_history())
        with self._cond:
            self._message = ('fault reset (controlword bit 7): the drive restarted and was configured again; '
                             'enable the axis to move it')

    # -- modes --------------------------------------------------------------------------------------
    def _moving(self) -> bool:
        speed = self.node.read(*self.key['velocity'])
        return speed is not None and abs(int(speed)) * o.SPEED_RPM_PER_BIT > STANDSTILL_RPM

    def set_mode(self, mode: int | str, timeout: float | None = None) -> None:
        """0x6060 (write-only) confirmed by 0x6061; only at standstill; 0xFA only with PTBASE = SYNC."""
        self._require_available()
        code = parse_family_mode(mode)
        self._check_supported(code)
        if code == self._mode and self._value('mode_display') == code:
            return
        if code == o.MODE_TRAJECTORY:
            problem = self.trajectory_period_problem()
            if problem:
                raise AxisError(f'{self._where()}: mode {mode_label(code)} refused: {problem}')
        if self.state is State.OPERATION_ENABLED and self._moving():
            raise AxisError(f'{self._where()}: the SERVOSTAR changes modes only at standstill; stop the motor '
                            f'before switching to {mode_label(code)}')
        super().set_mode(code, timeout)

    def trajectory_period_problem(self) -> str:
        """Why mode 0xFA cannot run at the SYNC period ('' when it can)."""
        if self.ptbase_period is None:
            return ''
        if abs(self.ptbase_period - self.cycle_period) > 1e-6:
            return (f'PTBASE (0x35D5) is {self.ptbase_period * 1000:g} ms, the SYNC period '
                    f'{self.cycle_period * 1000:g} ms; set PTBASE = SYNC period / 250 us, SAVE and restart the drive')
        return ''

    def command_field(self) -> str | None:
        return 'position' if self._mode == o.MODE_TRAJECTORY else super().command_field()

    # -- trajectory setpoints -----------------------------------------------------------------------
    def step_limit(self) -> float | None:
        """The largest step (increments) between two setpoints: VLIM x the SYNC period."""
        return self.units.step_limit(self.cycle_period) if self.units is not None else None

    def _last_setpoint(self) -> int | None:
        value = self._targets.get('target_position', self._hold)
        return self._last_sent if value is None else value

    def _step_problem(self, target: int) -> str:
        limit, previous = self.step_limit(), self._last_setpoint()
        if limit is None or previous is None or abs(target - previous) < limit:
            return ''
        assert self.units is not None
        return (f'a step of {abs(target - previous)} increments from the last setpoint {previous} to {target} '
                f'reaches VLIM x period ({self.units.vlim_rpm:g} rpm x {self.cycle_period * 1000:g} ms = '
                f'{limit:.0f} increments)')

    def _apply_setpoint(self, setpoint: Setpoint) -> None:
        if setpoint.position is not None and self._mode == o.MODE_TRAJECTORY:
            problem = self._step_problem(self.config.scaling.position_to_device(setpoint.position))
            if problem:  # never sent: the stream stops, the axis holds its last setpoint (HALT)
                self._source = None
                self._halt = True
                self._message = f'{problem}: not sent, stream aborted, axis held (HALT)'
                log.warning('%s: %s', self._where(), self._message)
                return
        super()._apply_setpoint(setpoint)

    def check_command(self, position: float | None = None, velocity: float | None = None,
                      effort: float | None = None) -> None:
        if self._mode != o.MODE_TRAJECTORY:
            super().check_command(position, velocity, effort)
            return
        self._check_limits(position, velocity, effort)
        if velocity is not None or effort is not None:
            raise AxisError(f'{self._where()}: mode {mode_label(self._mode)} takes positions only')
        if not self.node.available:
            raise AxisError(f'{self._where()}: node not available (NMT {self.node.nmt_state})')
        if self.state is not State.OPERATION_ENABLED:
            raise AxisError(f'{self._where()}: {self.state.label}, not operation enabled; {self._way_out()}')
        if position is not None:
            with self._cond:
                problem = self._step_problem(self.config.scaling.position_to_device(position))
            if problem:
                raise AxisError(f'{self._where()}: {problem}; move there with a trajectory')

    def _cycle_targets(self, state: State, now: float) -> dict[str, int]:
        targets = super()._cycle_targets(state, now)
        if self._mode != o.MODE_TRAJECTORY or state is not State.OPERATION_ENABLED:
            self._hold = None
        elif 'target_position' in self._targets:
            self._hold = self._targets['target_position']
        else:  # enabled and idle: hold the last setpoint, never follow the actual position
            if self._hold is None:
                self._hold = targets.get('target_position')
            if self._hold is not None:
                targets['target_position'] = self._hold
        return targets

    def _write(self, name: str, value: int | float) -> None:
        if name == 'target_torque':
            return  # no torque target in the modes the bridge drives
        if name == 'target_velocity':
            if self._mode != o.MODE_PV or self.units is None:
                return
            si = self.config.scaling.velocity_to_si(value)
            value = self.units.pv_target(si, self.options, self.config.joint_type)
        elif name == 'target_position':
            if self._mode == o.MODE_PP:
                if self.units is not None:
                    super()._write('pp_target', self.units.to_user_units(int(value)))
                return
            self._last_sent = int(value)
            if self.units is not None:
                value = self.units.to_setpoint(int(value))
        super()._write(name, value)

    def commanded_position(self) -> float:
        if self._last_sent is None or self.state is not State.OPERATION_ENABLED or self._mode == o.MODE_PP:
            return super().commanded_position()
        return self.config.scaling.position_to_si(self._last_sent)

    def stop_deceleration(self) -> float:
        if self._stop_deceleration is None and self.config.limits.max_acceleration is None and self.units:
            vlim = self.units.joint_speed_limit(self.options, self.config.joint_type)
            if vlim and self.units.dec_ms:
                self._stop_deceleration = vlim / (self.units.dec_ms / 1000.0)
        if self._stop_deceleration is None:
            self._stop_deceleration = self.config.limits.max_acceleration or 1.0
        return self._stop_deceleration

    def state_key(self) -> tuple[object, ...]:
        return (*super().state_key(), self.fault_pending())

    def snapshot(self) -> AxisSnapshot:
        snapshot = super().snapshot()
        if snapshot.available and self.fault_pending():
            return replace(snapshot, fault=True)
        return snapshot
