"""The joint driver of an OPEN drive axis: no CiA 402 state machine, the drive runs on its RUN
logic function and CAN references (shared/drives/opendrive.md §4, §7).

What goes out (one RPDO by default, decided every cycle by :meth:`RunLogicDriver.on_cycle`):

- 0x201F, the fieldbus channel of the 32 standard logic input functions. The bridge owns two
  bits: RUN (bit 0, the enable) and the configured alarm reset function; every other bit is
  sent as it was read from the drive at boot (:meth:`RunLogicDriver.set_logic_word`).
- the speed reference (0x201A or 0x201D) and the torque reference 0x201C: the commanded
  value in the mode's reference, 0 in the other; both 0 whenever the axis is not enabled,
  halted, or its command stream went stale.

What comes back (TPDO every SYNC): 0x2021 (bit 0: RUN as the drive combines it, terminal AND
fieldbus AND serial), 0x2018 (alarms), the actual velocity (and torque, position) elements.

Intents wait (condition variable, woken by each TPDO) with the node's state-switch timeout:

- enable: RUN high; done when 0x2021 bit 0 reads 1. A drive whose terminal (or serial) RUN
  is low never confirms: the request is withdrawn and the error says so;
- disable / quick stop: references 0 and RUN low in the same RPDO; done when 0x2021 bit 0 is 0;
- halt: references 0, RUN kept (resume lets commands through again);
- fault reset: a rising edge of the alarm reset function (one cycle low, then high until
  done); done when 0x2018 reads 0 or the reset EMCY (0x00xx, no alarm left) arrives; fails
  naming the alarms still active. RUN is dropped when an alarm trips, so a reset never
  restarts the motor;
- RUN that drops while enabled (terminal opened) withdraws the bridge's RUN too: the drive
  never starts again by itself, nor after the node was lost or rebooted (:meth:`on_node_reset`).

Modes: the two CiA 402 codes the ROS layer knows label the two references: 3 (pv, speed)
and 4 (pt, torque). Which one the drive acts upon is its own parameter (not in the appendix).
Direct commands and velocity streams feed a dead-man: silent for ``command_timeout``, the
references go to 0 and the snapshot says the command is stale.

Position: the drive has no position reference, so position commands are refused, unless the
axis sets ``position_loop`` (gain, following error): then pv streams trajectories through the
bridge's own loop (StreamStrategy.POSITION_LOOP: velocity = feed-forward + gain x error, on the measured or
integrated position) and takes position commands; a following error beyond the limit stops
the stream and halts the axis (references 0, RUN kept).
"""
from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.modes import Mode, mode_name, parse_mode
from drive_bridge.cia402.statemachine import State
from drive_bridge.families.opendrive import objects as od
from drive_bridge.families.opendrive.alarms import alarm_text, emcy_alarm_word
from drive_bridge.families.opendrive.errors import RunLogicError
from drive_bridge.families.opendrive.options import DriveOptions
from drive_bridge.families.opendrive.units import Units
from drive_bridge.joint import AxisSnapshot, BufferFeeder, DriveState, NodeIo, Setpoint, SetpointSource
from drive_bridge.joint.faults import fault_refusal
from drive_bridge.joint.limits import limit_problem
from drive_bridge.joint.position_loop import PositionLoop
from drive_bridge.joint.setpoint_guard import SetpointGuard
from drive_bridge.joint.strategy import StreamStrategy
from drive_bridge.model import AxisConfig, Timeouts

PV = int(Mode.PROFILE_VELOCITY)
PT = int(Mode.PROFILE_TORQUE)
MODES = (PV, PT)
ESTIMATED = 'position estimated (integrated from velocity)'
AT_REST_UNITS = 16  # |actual velocity element| at most this (0.1 % of its 16384 full scale): at rest
Key = tuple[int, int]


class RunLogicDriver:
    """One OPEN drive axis mapped to one joint (implements ``drive_bridge.joint.JointDriver``)."""

    def __init__(self, node: NodeIo, config: AxisConfig, timeouts: Timeouts, cycle_period: float,
                 family: str = 'opendrive') -> None:
        self.node = node
        self.config = config
        self.timeouts = timeouts
        self.cycle_period = cycle_period
        self.joint = config.joint
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
        self._owned = od.RUN_BIT | 1 << self.options.alarm_reset_function
        self._cond = threading.Condition()
        self._base = 0  # the bits of 0x201F the bridge does not own, as read at boot
        self._run = False  # the bridge's fieldbus RUN
        self._confirmed = False  # RUN was read back high since the last enable
        self._halt = False
        self._reset_phase = 0  # 0 idle, 1 reset bit low (this cycle), 2 high
        self._mode = config.mode if config.mode in MODES else PV
        self._speed = 0  # raw references while commanded
        self._torque = 0
        self._source: SetpointSource | None = None
        self._loop = PositionLoop(config.position_loop, config.limits) if config.position_loop.enabled else None
        self._loop_target: tuple[float, float] | None = None  # (desired position, velocity feed-forward), SI
        self._last_command = 0.0  # monotonic time of the last command / set-point
        self._stale = False
        self._message = ''
        self._written: dict[Key, int] = {}
        self._guard = SetpointGuard(cycle_period)
        self._refused = ''  # why the cycle check last refused a reference
        self._reset_mark: EmcyEvent | None = None  # the newest EMCY at the last fault reset: it and older are history
        # position: unwrapped counts of the configured quantity, or integrated velocity (rad)
        self._counts = 0
        self._last_raw: int | None = None
        self._estimate = 0.0
        self._last_velocity: tuple[float, float] | None = None  # (SI velocity, stamp)
        node.add_input_listener(self._on_input)

    # -- bus side (Notifier thread) -------------------------------------------------------------
    def _on_input(self, keys: frozenset[Key], stamp: float) -> None:
        position_key = self.key.get('position')
        if position_key is not None and position_key in keys:
            raw = self.node.read(*position_key)
            if raw is not None:
                raw = int(raw)
                if self._last_raw is not None:
                    self._counts += (raw - self._last_raw + 0x8000) % 0x10000 - 0x8000
                else:
                    self._counts = raw
                self._last_raw = raw
        elif position_key is None and self.key['velocity'] in keys:
            raw = self.node.read(*self.key['velocity'])
            if raw is not None:
                velocity = self.units.velocity_si(raw)
                last = self._last_velocity
                if last is not None and stamp > last[1]:
                    self._estimate += (velocity + last[0]) / 2 * (stamp - last[1])
                self._last_velocity = (velocity, stamp)
        if self.key['run'] in keys or self.key['alarms'] in keys:
            with self._cond:
                self._cond.notify_all()

    def set_logic_word(self, word: int) -> None:
        """The 0x201F value read from the drive at boot: its bits outside RUN and the alarm
        reset function are sent unchanged from now on."""
        with self._cond:
            self._base = int(word) & 0xFFFFFFFF & ~self._owned

    def _read(self, name: str) -> int | None:
        value = self.node.read(*self.key[name])
        return None if value is None else int(value)

    def _alarms(self) -> int:
        return self._read('alarms') or 0

    def _running(self) -> bool:
        return bool((self._read('run') or 0) & od.RUN_BIT)

    # -- protocol state ---------------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        """RUN has been read back once (the first TPDO), so outputs can be decided."""
        return self._read('run') is not None

    @property
    def node_id(self) -> int:
        return self.node.node_id

    @property
    def available(self) -> bool:
        return self.node.available

    @property
    def halted(self) -> bool:
        return self._halt

    @property
    def mode(self) -> int:
        return self._mode

    @property
    def drive_state(self) -> DriveState:
        """From RUN (read back and requested) and the alarms: fault while any alarm is set;
        enabled while RUN reads high at the bridge's request; stopping while it still reads
        high after the bridge dropped it; ready while an enable waits for it; else disabled."""
        run = self._read('run')
        if not self.node.available or run is None:
            return DriveState.UNAVAILABLE
        if self._alarms():
            return DriveState.FAULT
        if run & od.RUN_BIT:
            return DriveState.ENABLED if self._run else DriveState.STOPPING
        return DriveState.READY if self._run else DriveState.DISABLED

    # -- each cycle (cycle thread, never blocks) ----------------------------------------------------
    def on_cycle(self, now: float) -> None:
        """Decide this cycle's logic word and references."""
        alarms = self._alarms()
        running = self._running()
        with self._cond:
            if self._run and alarms:
                self._run = False
                self._message = f'{alarm_text(alarms)}: RUN dropped; reset the fault, then enable again'
            elif self._run and running:
                self._confirmed = True
            elif self._run and self._confirmed:
                self._run = False
                self._message = ('RUN dropped by the drive (0x2021 bit 0 low: terminal RUN opened?); '
                                 'enable again to move')
            enabled = self._run and running and not alarms
            if not enabled:  # commands never survive a drop-out
                self._clear_commands()
            elif self._halt:
                self._speed = self._torque = 0
            else:
                self._follow(now)
                self._check_references(now)
            if not enabled or self._halt:
                self._guard.seed('velocity', 0.0, now)
            speed = self._speed if self._mode == PV else 0
            torque = self._torque if self._mode == PT else 0
            word = self._base | (od.RUN_BIT if self._run else 0)
            if self._reset_phase == 2:
                word |= 1 << self.options.alarm_reset_function
            elif self._reset_phase == 1:
                self._reset_phase = 2  # low this cycle: the edge comes with the next one
        self._write('logic', word)
        self._write('speed', speed)
        self._write('torque_reference', torque)

    def _check_references(self, now: float) -> None:
        """The last check of this cycle's reference (``joint.setpoint_guard``): beyond the
        joint's limits, or (streamed through the bridge's loop) changed faster than they allow,
        it is never written; the axis is halted (references 0, RUN kept) or, with
        ``limits.on_violation: quick_stop``, stopped (RUN low), and the cause reported."""
        limits, units = self.config.limits, self.units
        streamed = self._source is not None and self._looped()
        if self._mode == PV:
            problem = self._guard.check(limits, 'velocity', self._speed * units.reference_per_unit, now,
                                        abs(units.reference_per_unit), streamed)
        else:
            problem = self._guard.check(limits, 'effort', self._torque * units.torque_per_unit, now,
                                        abs(units.torque_per_unit), False)
        if problem is None:
            return
        self._clear_commands()
        if self.config.limits.on_violation == 'quick_stop':
            self._run = False
        else:
            self._halt = True
        self._refused = (f'set-point refused before it was written: {problem}; axis held '
                         f'({"RUN low" if not self._run else "references 0, RUN kept"}, limits.on_violation)')
        self._message = self._refused
        self.node.report_setpoint_refused(self.joint, f'{self._where()}: {self._refused}')

    def _clear_commands(self) -> None:
        """References 0, no stream, no dead-man running (under the lock)."""
        self._speed = self._torque = 0
        self._source = None
        self._loop_target = None
        self._last_command, self._stale = 0.0, False

    def _follow(self, now: float) -> None:
        """The stream's set-point, then the dead-man, then the position loop (under the lock)."""
        if self._source is not None:
            setpoint = self._source(now)
            if setpoint is not None:
                self._apply(setpoint, saturate=True)
        timeout = self.timeouts.command_timeout
        if self._last_command and not self._stale and time.monotonic() - self._last_command > timeout:
            self._stale = True
            self._speed = self._torque = 0
            self._loop_target = None
            reference = f'0x{self.options.speed_reference:04X}' if self._mode == PV else '0x201C'
            self._message = (f'no command for {timeout * 1000:.0f} ms in {mode_name(self._mode)}: '
                             f'references 0 ({reference} = 0)')
        if self._loop_target is not None and self._looped():
            self._close_loop()

    def _looped(self) -> bool:
        return self._loop is not None and self._mode == PV

    def _close_loop(self) -> None:
        """One step of the bridge's position loop on the measured (or integrated) position."""
        assert self._loop is not None and self._loop_target is not None
        measured = self._position()
        if math.isnan(measured):
            self._speed = 0
            return
        position, feed_forward = self._loop_target
        out = self._loop.step(position, feed_forward, measured, self.cycle_period)
        if out.exceeded and self._source is not None:  # supervised while a trajectory streams
            self._halt = True
            self._source = None
            self._loop_target = None
            self._speed = 0
            self._message = (f'following error {out.error:.4g} beyond the position loop limit '
                             f'{self.config.position_loop.following_error:.4g}: stream aborted, axis held '
                             '(references 0, RUN kept)')
            return
        self._speed = self.units.speed_raw_saturated(out.velocity)

    def _apply(self, setpoint: Setpoint, saturate: bool) -> None:
        if setpoint.position is not None and self._looped():
            if self._loop_target is None and self._loop is not None:
                velocity = self._read('velocity')
                start = self.units.velocity_si(velocity) if velocity is not None else 0.0
                self._loop.reset(start)
                self._guard.rebase('velocity', start)
            self._loop_target = (setpoint.position, setpoint.velocity or 0.0)
            self._last_command = time.monotonic()
            self._stale = False
            return
        if setpoint.velocity is not None and self._mode == PV:
            self._loop_target = None
            self._speed = (self.units.speed_raw_saturated(setpoint.velocity) if saturate
                           else self.units.speed_raw(setpoint.velocity) or 0)
        if setpoint.effort is not None and self._mode == PT:
            self._torque = (self.units.torque_raw_saturated(setpoint.effort) if saturate
                            else self.units.torque_raw(setpoint.effort) or 0)
        self._last_command = time.monotonic()
        self._stale = False

    def _write(self, name: str, value: int) -> None:
        key = self.key[name]
        if self._written.get(key) != value:
            self._written[key] = value
            self.node.write(*key, value)

    def stop_run_on(self, by_sdo: bool) -> bool:
        """The drive runs on by itself and its master liveness is lost while it still sends: RUN
        low and references 0 in this cycle's RPDO (``by_sdo``: written by SDO too); every intent
        dropped. True once its speed reads (about) 0: at rest."""
        with self._cond:
            self._run = self._confirmed = False
            self._clear_commands()
            if not by_sdo:
                self._message = 'liveness lost while the drive still sends: stopping it (RUN low, references 0)'
            word = self._base
        for name, value in (('logic', word), ('speed', 0), ('torque_reference', 0)):
            if by_sdo:  # the process image is the cycle's: left as the PDO path writes it
                self.node.sdo_write(*self.key[name], value)
            else:
                self._written[self.key[name]] = value
                self.node.write(*self.key[name], value)
        velocity = self._read('velocity')
        return velocity is not None and abs(velocity) <= AT_REST_UNITS

    def on_node_reset(self) -> None:
        """The node is configured again (rebooted, or answers again after a loss): every intent
        is dropped and the outputs are written again on the next cycle, RUN low and references
        0, so the drive is never re-enabled by itself."""
        with self._cond:
            self._run = False
            self._confirmed = False
            self._halt = False
            self._reset_phase = 0
            self._clear_commands()
            self._written.clear()
            self._last_raw = None
            self._last_velocity = None
            self._message = 'node configured again: enable the axis to move it'
            self._cond.notify_all()

    # -- intents (any thread but the CAN Notifier) ------------------------------------------------------
    def _where(self) -> str:
        return f'axis {self.joint!r} (node {self.node.node_id} {self.node.name}, family {self.family!r})'

    def _require_available(self) -> None:
        if not self.node.available:
            raise RunLogicError(f'{self._where()}: node not available (NMT {self.node.nmt_state}); '
                                'wait for it to boot or check its node guarding')

    def _state_text(self) -> str:
        run, alarms = self._read('run'), self._read('alarms')
        run_text = 'no 0x2021 received' if run is None else f'0x2021 = 0x{run:08X}'
        alarm_part = f', {alarm_text(alarms)}' if alarms else ''
        return f'{self.drive_state.label}, {run_text}{alarm_part}'

    def _wait(self, done: Callable[[], bool], timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        with self._cond:
            while not done():
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise RunLogicError(f'{self._where()}: {what} not reached after {timeout * 1000:.0f} ms '
                                        f'({self._state_text()})')
                self._cond.wait(min(remaining, 0.05))

    def _fault_text(self) -> str:
        alarms = self._alarms()
        return f'{alarm_text(alarms)} (0x2018 = 0x{alarms:04X})' if alarms else ''

    def enable(self, timeout: float | None = None) -> None:
        """Fieldbus RUN high; done when the drive reads RUN back high (0x2021 bit 0)."""
        self._require_available()
        if self._alarms():
            raise RunLogicError(f'{self._where()}: {self.fault_description()}')
        with self._cond:
            self._run, self._confirmed, self._halt = True, False, False
            self._clear_commands()
            self._message = self._refused = ''
        wait = timeout if timeout is not None else self.timeouts.state_switch

        def confirmed() -> bool:
            if self._alarms():
                raise RunLogicError(f'{self._where()}: {self._fault_text()} while enabling')
            if not self._run:
                raise RunLogicError(f'{self._where()}: enabling was withdrawn ({self._message or "disabled"})')
            return self._running()
        try:
            self._wait(confirmed, wait, 'RUN (0x2021 bit 0)')
        except RunLogicError as exc:
            with self._cond:
                self._run = False
            if 'not reached' in str(exc):
                raise RunLogicError(f'{self._where()}: RUN not confirmed by the drive within {wait * 1000:.0f} ms: '
                                    'terminal RUN low (RUN = terminal AND fieldbus AND serial; the bridge sets the '
                                    'fieldbus channel only); fieldbus RUN withdrawn') from None
            raise

    def _stop(self, timeout: float | None, what: str) -> None:
        self._require_available()
        with self._cond:
            self._run, self._confirmed, self._halt = False, False, False
            self._clear_commands()
            self._message = ''
        wait = timeout if timeout is not None else self.timeouts.state_switch
        self._wait(lambda: not self._running(), wait, f'{what}: RUN low (0x2021 bit 0)')

    def disable(self, timeout: float | None = None) -> None:
        """References 0 and fieldbus RUN low (one RPDO); done when RUN reads back low."""
        self._stop(timeout, 'disable')

    def quick_stop(self, timeout: float | None = None) -> None:
        """The drive has no quick stop of its own: as disable (references 0, RUN low)."""
        self._stop(timeout, 'quick stop')

    def halt(self, on: bool = True) -> None:
        """References 0 with RUN kept (the drive decelerates as its own ramps say); off lets
        new commands through."""
        self._require_available()
        with self._cond:
            self._halt = on
            self._clear_commands()
            if not on and self._refused:
                self._message = self._refused = ''

    def reset_fault(self, timeout: float | None = None) -> None:
        """A rising edge of the alarm reset function; done when 0x2018 reads 0 or the reset EMCY
        (0x00xx, no alarm left) arrives; fails naming the alarms while their cause persists."""
        self._require_available()
        alarms = self._alarms()
        if not alarms:
            return
        before = self.node.emcy_history()  # (kept: identity tells the new events)
        with self._cond:
            self._run = False
            self._reset_phase = 1
        wait = timeout if timeout is not None else self.timeouts.state_switch

        def cleared() -> bool:
            if not self._alarms():
                return True
            return any(e.is_reset and not emcy_alarm_word(e.manufacturer) and not any(e is b for b in before)
                       for e in self.node.emcy_history())
        bit = self.options.alarm_reset_function
        try:
            self._wait(cleared, wait, f'fault reset (alarm reset function {bit}, 0x201F bit {bit})')
        except RunLogicError:
            left = self._alarms() or alarms
            raise RunLogicError(f'{self._where()}: fault reset failed: {alarm_text(left)} still active '
                                f'(0x2018 = 0x{left:04X}) {wait * 1000:.0f} ms after the reset edge: its cause '
                                'persists') from None
        finally:
            with self._cond:
                self._reset_phase = 0
        # the EMCY may come before the TPDO: let 0x2018 catch up (bounded, never fails)
        deadline = time.monotonic() + 5 * self.cycle_period + 0.1
        with self._cond:
            while self._alarms() and time.monotonic() < deadline:
                self._cond.wait(0.01)
        history = self.node.emcy_history()
        self._reset_mark = history[-1] if history else None
        self._message = ''

    def set_mode(self, mode: int | str, timeout: float | None = None) -> None:
        """pv (speed reference) or pt (torque reference): the bridge's choice of reference; the
        drive's own parameters decide whether it runs speed or torque control."""
        try:
            code = parse_mode(mode)
        except ValueError as exc:
            raise RunLogicError(f'{self._where()}: {exc}') from None
        if code not in MODES:
            raise RunLogicError(f'{self._where()}: family {self.family!r} has no mode {mode_name(code)}: it takes '
                                f'pv (speed reference 0x{self.options.speed_reference:04X}) and pt (torque '
                                'reference 0x201C) only (no CiA 402)')
        self._require_available()
        with self._cond:
            if code != self._mode:
                self._clear_commands()
            self._mode = code

    def home(self, timeout: float | None = None) -> None:
        raise RunLogicError(f'{self._where()}: family {self.family!r} has no homing (no CiA 402, no position '
                            'reference); reference the joint outside the drive')

    def check_command(self, position: float | None = None, velocity: float | None = None,
                      effort: float | None = None) -> None:
        """Raise if the command cannot be applied now: position commands (none on this family),
        the wrong field for the mode, limits, the drive's INT16 range, state."""
        limits = self.config.limits
        if position is not None and not self._looped():
            loop = ' (or set the axis\' position_loop to close a position loop in the bridge)' \
                if self._loop is None else ' (the axis\' position loop works in pv)'
            raise RunLogicError(f'{self._where()}: family {self.family!r} takes no position commands (no position '
                                f'reference on the drive); command velocity in pv or effort in pt{loop}')
        problem = limit_problem(limits, position, velocity, effort)
        if problem:
            raise RunLogicError(f'{self._where()}: {problem}')
        if velocity is not None:
            if self._mode != PV:
                raise RunLogicError(f'{self._where()}: a velocity command needs pv; mode is {mode_name(self._mode)}')
            if self.units.speed_raw(velocity) is None:
                low, high = self.units.velocity_range()
                raise RunLogicError(f'{self._where()}: velocity {velocity:.6g} is beyond the drive\'s range '
                                    f'{low:.6g}..{high:.6g} (0x{self.options.speed_reference:04X} is INT16, '
                                    f'16384 = n_MAX {self.options.n_max_rpm:g} rpm): refused, not wrapped')
        if effort is not None:
            if self._mode != PT:
                raise RunLogicError(f'{self._where()}: an effort command needs pt; mode is {mode_name(self._mode)}')
            if self.units.torque_raw(effort) is None:
                low, high = self.units.effort_range()
                raise RunLogicError(f'{self._where()}: effort {effort:.6g} is beyond the drive\'s range '
                                    f'{low:.6g}..{high:.6g} (0x201C is INT16, 4095 = T_nom '
                                    f'{self.options.rated_torque:g} N·m): refused, not wrapped')
        if not self.node.available:
            raise RunLogicError(f'{self._where()}: node not available (NMT {self.node.nmt_state})')
        if self.drive_state is DriveState.FAULT:
            raise RunLogicError(f'{self._where()}: {self.fault_description()}')
        if self.drive_state is not DriveState.ENABLED:
            raise RunLogicError(f'{self._where()}: {self._state_text()}, not enabled; enable it first (~/enable)')
        if self._halt:
            raise RunLogicError(f'{self._where()}: halted (references 0); resume first')

    def command(self, position: float | None = None, velocity: float | None = None,
                effort: float | None = None) -> None:
        """Set the reference (non-blocking; sent on the next cycle); feeds the dead-man."""
        self.check_command(position, velocity, effort)
        with self._cond:
            self._source = None
            self._apply(Setpoint(position=position, velocity=velocity, effort=effort), saturate=False)

    def wait_target_reached(self, timeout: float) -> None:
        raise RunLogicError(f'{self._where()}: family {self.family!r} has no position target to reach')

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
            raise RunLogicError(f'{self._where()}: a trajectory needs pv (velocity references); mode is '
                                f'{mode_name(self._mode)}')
        if not has_velocities and not self._looped():
            raise RunLogicError(f'{self._where()}: family {self.family!r} has no position reference: a trajectory '
                                'of positions only is refused; give velocities (followed open loop), or configure '
                                'a position quantity and position_loop')

    def commanded_position(self) -> float:
        target = self._loop_target
        return target[0] if target is not None and self._looped() else self._position()

    def stop_deceleration(self) -> float:
        """The joint's max_acceleration, else full speed n_MAX to rest in one second."""
        value = self.config.limits.max_acceleration
        return value if value else abs(self.units.n_max * self.units.joint_per_motor)

    def set_setpoint_source(self, source: SetpointSource | None) -> None:
        with self._cond:
            self._source = source
            if source is None and self._last_command:
                self._last_command = time.monotonic()  # the dead-man then stops if nothing follows

    def set_buffer_feeder(self, feeder: BufferFeeder | None) -> None:
        if feeder is not None:
            raise RunLogicError(f'{self._where()}: family {self.family!r} has no interpolation buffer (PVT)')

    def interpolation_free_slots(self) -> int | None:
        return None

    def pvt_time_unit(self) -> float | None:
        return None

    def push_interpolation_point(self, position: int, time_units: int, velocity: int) -> None:
        raise RunLogicError(f'{self._where()}: family {self.family!r} has no interpolation buffer (PVT)')

    def is_stream_fault(self, event: EmcyEvent) -> bool:
        return False

    def fault_description(self) -> str:
        """The alarms (0x2018) and the last EMCY, and the way out."""
        alarms = self._alarms()
        return fault_refusal(self.last_emcy(), [self._fault_text()] if alarms else [])

    # -- state -----------------------------------------------------------------------------------
    def last_emcy(self) -> EmcyEvent | None:
        for event in reversed(self.node.emcy_history()):
            if event is self._reset_mark:
                break
            if not event.is_reset:
                return event
        return None

    def _position(self) -> float:
        if self.options.position is None:
            return self._estimate if self._last_velocity is not None else math.nan
        return self.units.position_si(self._counts) if self._last_raw is not None else math.nan

    def feedback(self) -> tuple[bool, float, float, float, float]:
        velocity = self._read('velocity')
        torque = self._read('torque') if 'torque' in self.key else None
        return (self.node.available and velocity is not None, self._position(),
                self.units.velocity_si(velocity) if velocity is not None else math.nan,
                self.units.torque_si(torque) if torque is not None else math.nan,
                self.node.stamp(*self.key['velocity']))

    def state_key(self) -> tuple[object, ...]:
        return (self.node.available, self.drive_state, self._alarms(), self._mode, self._halt, self._stale,
                self._message)

    def snapshot(self) -> AxisSnapshot:
        _available, position, velocity, effort, stamp = self.feedback()
        alarms = self._alarms()
        ready = self._read('run') is not None
        notes = [self._message] if self._message else []
        if alarms and not self._message.startswith(alarm_text(alarms)):
            notes.insert(0, alarm_text(alarms))
        if self.options.position is None:
            notes.append(ESTIMATED)
        return AxisSnapshot(
            joint=self.joint, node_id=self.node.node_id, node_name=self.node.name, slot=self.config.slot,
            available=self.node.available and ready, nmt_state=self.node.nmt_state,
            drive_state=self.drive_state, state=State.UNKNOWN, statusword=0, controlword=0,
            mode=self._mode, mode_name=mode_name(self._mode), requested_mode=self._mode,
            position=position, velocity=velocity, effort=effort, stamp=stamp,
            fault=bool(alarms), warning=False, target_reached=False, internal_limit=False,
            following_error=False, halted=self._halt, command_stale=self._stale, last_emcy=self.last_emcy(),
            message='; '.join(notes), setpoint_refused=self._refused)
