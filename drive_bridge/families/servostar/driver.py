"""The quirks of a SERVOSTAR: what its CiA 402 axis does differently (handed to the axis as
:class:`ServostarQuirks`; shared/drives/servostar-400-600.md §3, §4, §5).

- **No Fault state.** The statusword never shows the Fault pattern: a fault is bit 31 of the
  status register 0x1002 (TPDO 1) or an EMCY of category 1, 2 or 4 whose follow-up (code 0x0000)
  still reports a pending error register. The axis then reports the device state FAULT (and so
  the drive-independent state ``fault``), refuses to enable, and :meth:`ServostarQuirks.reset_fault` clears it
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
from collections.abc import Sequence
from dataclasses import replace

from drive_bridge.cia402 import statemachine as sm
from drive_bridge.cia402.errors import AxisError
from drive_bridge.cia402.modes import mode_name, parse_mode
from drive_bridge.cia402.quirks import AxisPort, AxisQuirks, Output
from drive_bridge.cia402.statemachine import State
from drive_bridge.families.servostar import emcy, objects as o
from drive_bridge.families.servostar.options import AxisOptions
from drive_bridge.families.servostar.units import DriveUnits
from drive_bridge.joint import Setpoint
from drive_bridge.model import AxisConfig

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


class ServostarQuirks(AxisQuirks):
    """The one axis of a SERVOSTAR node."""

    def __init__(self, config: AxisConfig) -> None:
        self.options = AxisOptions.of(config.drive)
        self.units: DriveUnits | None = None
        self.ptbase_period: float | None = None  # s, PTBASE as read at boot
        self._configured_limit = config.limits.max_velocity
        self._node_resets = 0
        self._reset_stamp = 0.0
        self._hold: int | None = None  # mode 0xFA, enabled and idle: the setpoint held
        self._device_state = State.UNKNOWN  # as the statusword shows it (no Fault pattern ever)
        self._last_sent: int | None = None  # the last trajectory setpoint, in device units (2^20 / rev)
        self._emcy_marker: tuple[int, int] = (0, 0)
        self._emcy_faults: dict[int, int] = {}  # code -> category, pending by the EMCY state machine

    def attach(self, axis: AxisPort) -> None:
        super().attach(axis)
        axis.key.update(status_register=(o.STATUS_REGISTER, 0), pp_target=o.TARGET_POSITION_PP)

    # -- boot ---------------------------------------------------------------------------------------
    def apply_units(self, units: DriveUnits, ptbase_period: float | None) -> None:
        """The drive's units and limits as read at boot: SI scaling, max_velocity = VLIM at the joint
        unless the config gives less (the caller checked that it does not give more)."""
        config = self.axis.config
        scaling = units.scaling(self.options, config.joint_type)
        vlim = units.joint_speed_limit(self.options, config.joint_type)
        limit = self._configured_limit if vlim is None or (
            self._configured_limit is not None and self._configured_limit <= vlim) else vlim
        with self.axis.lock:
            self.units = units
            self.ptbase_period = ptbase_period
            self.axis.update_config(replace(config, scaling=scaling, limits=replace(config.limits, max_velocity=limit)))

    def on_node_reset(self) -> None:
        self._node_resets += 1
        self._reset_stamp = time.time()
        self._hold = None

    # -- faults -------------------------------------------------------------------------------------
    def _pending_emcy_faults(self) -> dict[int, int]:
        """code -> category of the faults the EMCYs report pending (the drive's error state
        machine: a fault EMCY, then code 0x0000 frames whose register is what is left)."""
        history = self.axis.node.emcy_history()
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
        register = self.axis.read('status_register')
        return register is not None and bool(int(register) & o.DRVSTAT_ERROR_PENDING)

    def fault_pending(self) -> bool:
        """The drive reports a fault (0x1002 bit 31, or a fault EMCY still pending)."""
        return self._register_fault() or bool(self._pending_emcy_faults())

    def state_of(self, statusword: int) -> State:
        state = super().state_of(statusword)
        self._device_state = state
        return State.FAULT if self.fault_pending() else state

    def fault_hold(self, state: State) -> int | None:
        """In a fault the drive reacts by itself: category 2 brakes on the emergency ramp with the
        output stage on (the controlword keeps the state the statusword shows: never "disable
        voltage" under a braking drive), categories 1 and 4 switch the stage off (disable
        voltage, so no enable command reaches it); the axis adds the reset bit's edge."""
        if state is not State.FAULT:
            return None
        if self._fault_categories() - {2}:  # the drive switched its output stage off
            return sm.CMD_DISABLE_VOLTAGE
        return sm.hold_command(self._device_state)  # category 2: it brakes, its stage on

    def _fault_categories(self) -> set[int]:
        categories = set(self._pending_emcy_faults().values())
        if self._register_fault() and not categories:
            categories.add(0)  # pending without an EMCY the bridge saw: the reset restarts the drive
        return categories

    def reset_fault(self, timeout: float | None) -> None:
        """Category 2 by the rising edge of bit 11; categories 1 and 4 (or unknown) by bit 7,
        after which the drive restarts and is configured again by the master (waited for)."""
        axis = self.axis
        if axis.state is not State.FAULT:
            return
        if not self._fault_categories() - {2}:
            axis.reset_by_edge(o.CW_ACKNOWLEDGE, timeout)
            axis.say('fault acknowledged (controlword bit 11)')
            return
        resets = self._node_resets
        wait = timeout if timeout is not None else max(5.0, 3 * axis.timeouts.boot + axis.timeouts.state_switch)

        def back() -> bool:
            return (self._node_resets > resets and axis.node.available
                    and axis.node.stamp(*axis.key['statusword']) > self._reset_stamp and not self.fault_pending())

        def failed() -> str:
            return 'it restarted, but the fault is still present' if self._node_resets > resets else \
                'it did not restart'
        axis.reset_by_edge(o.CW_RESET_FAULT, wait, back,
                           'fault reset (controlword bit 7: the drive restarts and is configured again)', failed)
        axis.say('fault reset (controlword bit 7): the drive restarted and was configured again; '
                 'enable the axis to move it')

    # -- modes --------------------------------------------------------------------------------------
    def _moving(self) -> bool:
        speed = self.axis.node.read(*self.axis.key['velocity'])
        return speed is not None and abs(int(speed)) * o.SPEED_RPM_PER_BIT > STANDSTILL_RPM

    def parse_mode(self, mode: int | str) -> int:
        return parse_family_mode(mode)

    def before_mode_change(self, code: int) -> bool:
        """0x6060 (write-only) confirmed by 0x6061; only at standstill; 0xFA only with PTBASE = SYNC."""
        axis = self.axis
        if code == axis.mode and axis.read('mode_display') == code:
            return False
        if code == o.MODE_TRAJECTORY:
            problem = self.trajectory_period_problem()
            if problem:
                raise AxisError(f'{axis.where()}: mode {mode_label(code)} refused: {problem}')
        if axis.state is State.OPERATION_ENABLED and self._moving():
            raise AxisError(f'{axis.where()}: the SERVOSTAR changes modes only at standstill; stop the motor '
                            f'before switching to {mode_label(code)}')
        return True

    def trajectory_period_problem(self) -> str:
        """Why mode 0xFA cannot run at the SYNC period ('' when it can)."""
        if self.ptbase_period is None:
            return ''
        period = self.axis.cycle_period
        if abs(self.ptbase_period - period) > 1e-6:
            return (f'PTBASE (0x35D5) is {self.ptbase_period * 1000:g} ms, the SYNC period '
                    f'{period * 1000:g} ms; set PTBASE = SYNC period / 250 us, SAVE and restart the drive')
        return ''

    def command_field(self, mode: int) -> str | None:
        return 'position' if mode == o.MODE_TRAJECTORY else super().command_field(mode)

    # -- trajectory setpoints -----------------------------------------------------------------------
    def step_limit(self) -> float | None:
        """The largest step (increments) between two setpoints: VLIM x the SYNC period."""
        return self.units.step_limit(self.axis.cycle_period) if self.units is not None else None

    def _last_setpoint(self) -> int | None:
        value = self.axis.intents.targets.get('target_position', self._hold)
        return self._last_sent if value is None else value

    def _step_problem(self, target: int) -> str:
        limit, previous = self.step_limit(), self._last_setpoint()
        if limit is None or previous is None or abs(target - previous) < limit:
            return ''
        assert self.units is not None
        return (f'a step of {abs(target - previous)} increments from the last setpoint {previous} to {target} '
                f'reaches VLIM x period ({self.units.vlim_rpm:g} rpm x {self.axis.cycle_period * 1000:g} ms = '
                f'{limit:.0f} increments)')

    def setpoint_refusal(self, setpoint: Setpoint) -> str:
        """A trajectory step of VLIM x period or more is never sent: the stream stops (HALT)."""
        if setpoint.position is None or self.axis.mode != o.MODE_TRAJECTORY:
            return ''
        problem = self._step_problem(self.axis.config.scaling.position_to_device(setpoint.position))
        if not problem:
            return ''
        message = f'{problem}: not sent, stream aborted, axis held (HALT)'
        log.warning('%s: %s', self.axis.where(), message)
        return message

    def check_command(self, position: float | None, velocity: float | None, effort: float | None) -> bool:
        axis = self.axis
        if axis.mode != o.MODE_TRAJECTORY:
            return False
        axis.check_limits(position, velocity, effort)
        if velocity is not None or effort is not None:
            raise AxisError(f'{axis.where()}: mode {mode_label(axis.mode)} takes positions only')
        if not axis.node.available:
            raise AxisError(f'{axis.where()}: node not available (NMT {axis.node.nmt_state})')
        if axis.state is not State.OPERATION_ENABLED:
            raise AxisError(f'{axis.where()}: {axis.state.label}, not operation enabled; {axis.way_out()}')
        if position is not None:
            with axis.lock:
                problem = self._step_problem(axis.config.scaling.position_to_device(position))
            if problem:
                raise AxisError(f'{axis.where()}: {problem}; move there with a trajectory')
        return True

    def cycle_targets(self, state: State, targets: dict[str, int]) -> dict[str, int]:
        commanded = self.axis.intents.targets
        if self.axis.mode != o.MODE_TRAJECTORY or state is not State.OPERATION_ENABLED:
            self._hold = None
        elif 'target_position' in commanded:
            self._hold = commanded['target_position']
        else:  # enabled and idle: hold the last setpoint, never follow the actual position
            if self._hold is None:
                self._hold = targets.get('target_position')
            if self._hold is not None:
                targets['target_position'] = self._hold
        return targets

    def outputs(self, name: str, value: int | float) -> Sequence[Output]:
        mode, units = self.axis.mode, self.units
        if name == 'target_torque':
            return ()  # no torque target in the modes the bridge drives
        if name == 'target_velocity':
            if mode != o.MODE_PV or units is None:
                return ()
            si = self.axis.config.scaling.velocity_to_si(value)
            return ((name, units.pv_target(si, self.options, self.axis.config.joint_type)),)
        if name == 'target_position':
            if mode == o.MODE_PP:
                return (('pp_target', units.to_user_units(int(value))),) if units is not None else ()
            self._last_sent = int(value)
            if units is not None:
                return ((name, units.to_setpoint(int(value))),)
        return ((name, value),)

    def commanded_position(self) -> int | None:
        if self._last_sent is None or self.axis.state is not State.OPERATION_ENABLED or self.axis.mode == o.MODE_PP:
            return None
        return self._last_sent

    def stop_deceleration(self) -> float | None:
        """Without a max_acceleration limit: VLIM over the drive's ramp DEC (else 1 unit/s^2)."""
        config, units = self.axis.config, self.units
        if config.limits.max_acceleration is None and units:
            vlim = units.joint_speed_limit(self.options, config.joint_type)
            if vlim and units.dec_ms:
                return vlim / (units.dec_ms / 1000.0)
        return config.limits.max_acceleration or 1.0
