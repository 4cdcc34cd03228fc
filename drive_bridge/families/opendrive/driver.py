"""The joint driver of an OPEN drive axis: no CiA 402 state machine, the drive runs on its RUN
logic function and CAN references (shared/drives/opendrive.md §4, §7). This module is the RUN
logic, the alarms and the fault reset; the references, commands and streaming are
:mod:`~drive_bridge.families.opendrive.references`', the position
:mod:`~drive_bridge.families.opendrive.feedback`'s, and the plumbing every joint driver
shares is the core's ``joint.driverbase.JointDriverBase``.

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
import time

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.modes import mode_name, parse_mode
from drive_bridge.cia402.statemachine import State
from drive_bridge.families.opendrive import objects as od
from drive_bridge.families.opendrive.alarms import alarm_text, emcy_alarm_word
from drive_bridge.families.opendrive.errors import RunLogicError
from drive_bridge.families.opendrive.references import MODES, PT, PV, Key, References
from drive_bridge.joint import AxisSnapshot, DriveState, NodeIo
from drive_bridge.joint.faults import fault_refusal
from drive_bridge.model import AxisConfig, Timeouts

ESTIMATED = 'position estimated (integrated from velocity)'
AT_REST_UNITS = 16  # |actual velocity element| at most this (0.1 % of its 16384 full scale): at rest


class RunLogicDriver(References):
    """One OPEN drive axis mapped to one joint (implements ``drive_bridge.joint.JointDriver``): its
    RUN logic, alarms and fault reset; the references are :class:`References`'."""

    def __init__(self, node: NodeIo, config: AxisConfig, timeouts: Timeouts, cycle_period: float,
                 family: str = 'opendrive') -> None:
        super().__init__(node, config, timeouts, cycle_period, family)
        self._owned = od.RUN_BIT | 1 << self.options.alarm_reset_function
        self._base = 0  # the bits of 0x201F the bridge does not own, as read at boot
        self._run = False  # the bridge's fieldbus RUN
        self._confirmed = False  # RUN was read back high since the last enable
        self._reset_phase = 0  # 0 idle, 1 reset bit low (this cycle), 2 high
        self._reset_mark: EmcyEvent | None = None  # the newest EMCY at the last fault reset: it and older are history
        node.add_input_listener(self._on_input)

    # -- bus side (Notifier thread) -------------------------------------------------------------
    def _on_input(self, keys: frozenset[Key], stamp: float) -> None:
        self.feedback_position.on_input(keys, stamp)
        if self.key['run'] in keys or self.key['alarms'] in keys:
            self.wake()

    def set_logic_word(self, word: int) -> None:
        """The 0x201F value read from the drive at boot: its bits outside RUN and the alarm
        reset function are sent unchanged from now on."""
        with self.lock:
            self._base = int(word) & 0xFFFFFFFF & ~self._owned

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
        with self.lock:
            if self._run and alarms:
                self._run = False
                self.message = f'{alarm_text(alarms)}: RUN dropped; reset the fault, then enable again'
            elif self._run and running:
                self._confirmed = True
            elif self._run and self._confirmed:
                self._run = False
                self.message = ('RUN dropped by the drive (0x2021 bit 0 low: terminal RUN opened?); '
                                'enable again to move')
            enabled = self._run and running and not alarms
            if not enabled:  # commands never survive a drop-out
                self._clear_commands()
            elif self.halted:
                self._speed = self._torque = 0
            else:
                self._follow(now)
                self._check_references(now)
            if not enabled or self.halted:
                self.guard.seed('velocity', 0.0, now)
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

    def _run_off(self) -> None:
        self._run = False

    def _write(self, name: str, value: int) -> None:
        self.put(self.key[name], value)

    def stop_run_on(self, by_sdo: bool) -> bool:
        """The drive runs on by itself and its master liveness is lost while it still sends: RUN
        low and references 0 in this cycle's RPDO (``by_sdo``: written by SDO too); every intent
        dropped. True once its speed reads (about) 0: at rest."""
        with self.lock:
            self._run = self._confirmed = False
            self._clear_commands()
            if not by_sdo:
                self.message = 'liveness lost while the drive still sends: stopping it (RUN low, references 0)'
            word = self._base
        for name, value in (('logic', word), ('speed', 0), ('torque_reference', 0)):
            if by_sdo:  # the process image is the cycle's: left as the PDO path writes it
                self.node.sdo_write(*self.key[name], value)
            else:
                self.written[self.key[name]] = value
                self.node.write(*self.key[name], value)
        velocity = self._read('velocity')
        return velocity is not None and abs(velocity) <= AT_REST_UNITS

    def on_node_reset(self) -> None:
        """The node is configured again (rebooted, or answers again after a loss): every intent
        is dropped and the outputs are written again on the next cycle, RUN low and references
        0, so the drive is never re-enabled by itself."""
        with self.lock:
            self._run = False
            self._confirmed = False
            self.halted = False
            self._reset_phase = 0
            self._clear_commands()
            self.written.clear()
            self.feedback_position.forget()
            self.message = 'node configured again: enable the axis to move it'
            self.lock.notify_all()

    # -- intents (any thread but the CAN Notifier) ------------------------------------------------------
    def state_text(self) -> str:
        run, alarms = self._read('run'), self._read('alarms')
        run_text = 'no 0x2021 received' if run is None else f'0x2021 = 0x{run:08X}'
        alarm_part = f', {alarm_text(alarms)}' if alarms else ''
        return f'{self.drive_state.label}, {run_text}{alarm_part}'

    def _fault_text(self) -> str:
        alarms = self._alarms()
        return f'{alarm_text(alarms)} (0x2018 = 0x{alarms:04X})' if alarms else ''

    def enable(self, timeout: float | None = None) -> None:
        """Fieldbus RUN high; done when the drive reads RUN back high (0x2021 bit 0)."""
        self.require_available()
        if self._alarms():
            raise RunLogicError(f'{self.where()}: {self.fault_description()}')
        with self.lock:
            self._run, self._confirmed, self.halted = True, False, False
            self._clear_commands()
            self.message = self._refused = ''
        wait = timeout if timeout is not None else self.timeouts.state_switch

        def confirmed() -> bool:
            if self._alarms():
                raise RunLogicError(f'{self.where()}: {self._fault_text()} while enabling')
            if not self._run:
                raise RunLogicError(f'{self.where()}: enabling was withdrawn ({self.message or "disabled"})')
            return self._running()
        try:
            self.wait(confirmed, wait, 'RUN (0x2021 bit 0)')
        except RunLogicError as exc:
            with self.lock:
                self._run = False
            if 'not reached' in str(exc):
                raise RunLogicError(f'{self.where()}: RUN not confirmed by the drive within {wait * 1000:.0f} ms: '
                                    'terminal RUN low (RUN = terminal AND fieldbus AND serial; the bridge sets the '
                                    'fieldbus channel only); fieldbus RUN withdrawn') from None
            raise

    def _stop(self, timeout: float | None, what: str) -> None:
        self.require_available()
        with self.lock:
            self._run, self._confirmed, self.halted = False, False, False
            self._clear_commands()
            self.message = ''
        wait = timeout if timeout is not None else self.timeouts.state_switch
        self.wait(lambda: not self._running(), wait, f'{what}: RUN low (0x2021 bit 0)')

    def disable(self, timeout: float | None = None) -> None:
        """References 0 and fieldbus RUN low (one RPDO); done when RUN reads back low."""
        self._stop(timeout, 'disable')

    def quick_stop(self, timeout: float | None = None) -> None:
        """The drive has no quick stop of its own: as disable (references 0, RUN low)."""
        self._stop(timeout, 'quick stop')

    def halt(self, on: bool = True) -> None:
        """References 0 with RUN kept (the drive decelerates as its own ramps say); off lets
        new commands through."""
        self.require_available()
        with self.lock:
            self.halted = on
            self._clear_commands()
            if not on and self._refused:
                self.message = self._refused = ''

    def reset_fault(self, timeout: float | None = None) -> None:
        """A rising edge of the alarm reset function; done when 0x2018 reads 0 or the reset EMCY
        (0x00xx, no alarm left) arrives; fails naming the alarms while their cause persists."""
        self.require_available()
        alarms = self._alarms()
        if not alarms:
            return
        before = self.node.emcy_history()  # (kept: identity tells the new events)
        with self.lock:
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
            self.wait(cleared, wait, f'fault reset (alarm reset function {bit}, 0x201F bit {bit})')
        except RunLogicError:
            left = self._alarms() or alarms
            raise RunLogicError(f'{self.where()}: fault reset failed: {alarm_text(left)} still active '
                                f'(0x2018 = 0x{left:04X}) {wait * 1000:.0f} ms after the reset edge: its cause '
                                'persists') from None
        finally:
            with self.lock:
                self._reset_phase = 0
        # the EMCY may come before the TPDO: let 0x2018 catch up (bounded, never fails)
        deadline = time.monotonic() + 5 * self.cycle_period + 0.1
        with self.lock:
            while self._alarms() and time.monotonic() < deadline:
                self.lock.wait(0.01)
        history = self.node.emcy_history()
        self._reset_mark = history[-1] if history else None
        self.message = ''

    def set_mode(self, mode: int | str, timeout: float | None = None) -> None:
        """pv (speed reference) or pt (torque reference): the bridge's choice of reference; the
        drive's own parameters decide whether it runs speed or torque control."""
        try:
            code = parse_mode(mode)
        except ValueError as exc:
            raise RunLogicError(f'{self.where()}: {exc}') from None
        if code not in MODES:
            raise RunLogicError(f'{self.where()}: family {self.family!r} has no mode {mode_name(code)}: it takes '
                                f'pv (speed reference 0x{self.options.speed_reference:04X}) and pt (torque '
                                'reference 0x201C) only (no CiA 402)')
        self.require_available()
        with self.lock:
            if code != self._mode:
                self._clear_commands()
            self._mode = code

    def home(self, timeout: float | None = None) -> None:
        raise RunLogicError(f'{self.where()}: family {self.family!r} has no homing (no CiA 402, no position '
                            'reference); reference the joint outside the drive')

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

    def feedback(self) -> tuple[bool, float, float, float, float]:
        velocity = self._read('velocity')
        torque = self._read('torque') if 'torque' in self.key else None
        return (self.node.available and velocity is not None, self._position(),
                self.units.velocity_si(velocity) if velocity is not None else math.nan,
                self.units.torque_si(torque) if torque is not None else math.nan,
                self.node.stamp(*self.key['velocity']))

    def state_key(self) -> tuple[object, ...]:
        return (self.node.available, self.drive_state, self._alarms(), self._mode, self.halted, self.deadman.stale,
                self.message)

    def snapshot(self) -> AxisSnapshot:
        _available, position, velocity, effort, stamp = self.feedback()
        alarms = self._alarms()
        ready = self._read('run') is not None
        notes = [self.message] if self.message else []
        if alarms and not self.message.startswith(alarm_text(alarms)):
            notes.insert(0, alarm_text(alarms))
        if self.feedback_position.estimated:
            notes.append(ESTIMATED)
        return self.snapshot_of(
            available=self.node.available and ready,
            drive_state=self.drive_state, state=State.UNKNOWN, statusword=0, controlword=0,
            mode=self._mode, mode_name=mode_name(self._mode), requested_mode=self._mode,
            position=position, velocity=velocity, effort=effort, stamp=stamp,
            fault=bool(alarms), warning=False, target_reached=False, internal_limit=False,
            following_error=False, message='; '.join(notes), setpoint_refused=self._refused)
