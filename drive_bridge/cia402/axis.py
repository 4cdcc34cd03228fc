"""One CiA 402 axis, the joint driver of CiA 402 drives: the state machine driven from
intents (any thread), controlword and targets decided each cycle. Per-mode control (mode
bits, targets, set_mode, command, home, PVT) is the :class:`ModeControl` mixin.

The axis never blocks the cycle: :meth:`Axis.on_cycle` (called by the master just
before each SYNC) reads the latest statusword, decides the controlword that moves the
drive one transition toward the wanted state, adds the mode bits (PP set-point
handshake, homing start, IP enable, HALT) and writes targets. Intents such as
:meth:`enable` set what is wanted and wait, with a timeout, for the statusword to
confirm it. Process data goes through a :class:`NodeIo`, so the same logic serves
objects mapped in PDOs and objects reached by SDO.

The axis is built from parts: its motion intents (:class:`~drive_bridge.joint.intents.Intents`),
the modes it may take (:class:`~drive_bridge.cia402.modesupport.ModeSupport`), its interpolation
objects, and the :class:`~drive_bridge.cia402.quirks.AxisQuirks` its drive family hands in where
the drive differs from the profile (no family subclasses it).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402 import statemachine as sm
from drive_bridge.cia402.drive_limits import describe, with_drive_limits
from drive_bridge.cia402.errors import AxisError
from drive_bridge.cia402.interpolation import InterpolationObjects
from drive_bridge.cia402.modecontrol import PP_IDLE, ModeControl
from drive_bridge.cia402.modes import Mode, mode_name
from drive_bridge.cia402.modesupport import ModeSupport
from drive_bridge.cia402.profile import AxisObjects, Cia402Profile, FaultModel, PvtRecord, axis_keys
from drive_bridge.cia402.quirks import AxisQuirks
from drive_bridge.cia402.report import DRIVE_STATE, FaultReport
from drive_bridge.cia402.statemachine import State
from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint import AxisSnapshot, DriveState, NodeIo
from drive_bridge.joint.setpoint_guard import SetpointGuard
from drive_bridge.model import AxisConfig, Timeouts


class Axis(ModeControl):
    """A CiA 402 axis of one node slot, mapped to one joint."""

    def __init__(self, node: NodeIo, config: AxisConfig, timeouts: Timeouts, cycle_period: float = 0.004,
                 accepted_modes: frozenset[int] | None = None, profile: Cia402Profile | None = None,
                 quirks: AxisQuirks | None = None) -> None:
        super().__init__(node, config, timeouts, cycle_period)  # the period is also 0x60C2's
        self.profile = profile
        slot = config.slot
        self.key = axis_keys(slot, profile.axis_objects(slot) if profile is not None else AxisObjects.cia402(slot))
        self.interpolation = InterpolationObjects(node, self.key, cycle_period)
        self.pvt: PvtRecord | None = profile.pvt_record(slot) if profile is not None else None
        self.fault_model: FaultModel = profile.axes.fault_model if profile is not None else FaultModel()
        self._target_state: State | None = None
        self._stale_hold = False  # the node's inputs are stale (its intents were dropped)
        self._fault_reset_phase = 0  # 0 idle, 1 reset bit low, 2 reset bit high
        self._reset_bit = self.fault_model.reset_bit  # the bit of the running fault reset
        self._disable_on_return = False  # after the node was configured again (on_node_reset)
        self._last_state = State.UNKNOWN  # the state seen by the last cycle
        # an axis whose mode is picked at boot (on_booted) requests none until then
        self._mode = config.mode if config.auto_mode is None else int(Mode.NO_MODE)
        self._mode_problem = ''
        self._estimate: tuple[float, float, float] | None = None  # (position, stamp, velocity)
        self._pp_phase = PP_IDLE  # profile position set-point handshake
        self._pp_done = 0.0  # statusword stamp when the last handshake completed
        self._homing = False
        self._stop_deceleration: float | None = None
        self._controlword = 0
        self._pvt_guard = SetpointGuard(0.0)
        self._pvt_clock = 0.0
        self._setpoint_refused = ''
        self._configured_limits = config.limits
        self._limits_said = ''
        self.faults = FaultReport(node, self.key['error_code'], slot)
        # the drive family's list, when 0x6502 under-reports
        if accepted_modes is None and profile is not None:
            accepted_modes = profile.modes.accepted
        self.modes = ModeSupport(node, self.key['supported_modes'], accepted_modes)
        self.quirks = quirks if quirks is not None else AxisQuirks()
        self.quirks.attach(self)
        node.add_input_listener(self._on_input)

    # -- bus side ---------------------------------------------------------------------------
    def _on_input(self, keys: frozenset[tuple[int, int]], stamp: float) -> None:
        if self.config.estimated_velocity and self.key['position'] in keys:
            self._estimate_velocity(stamp)
        if self.key['statusword'] in keys or self.key['mode_display'] in keys:
            self.wake()

    def _estimate_velocity(self, stamp: float) -> None:
        """Velocity from two position samples (the drive's 0x606C is in no PDO)."""
        position = self.node.read(*self.key['position'])
        if position is None:
            return
        last = self._estimate
        velocity = 0.0
        if last is not None and stamp > last[1]:  # counts/s, in the drive's velocity units
            scaling = self.config.scaling
            velocity = (position - last[0]) / (stamp - last[1]) * scaling.position_factor / scaling.velocity_factor
        elif last is not None:
            velocity = last[2]
        self._estimate = (float(position), stamp, velocity)

    def read(self, name: str) -> int | float | None:
        if name == 'velocity' and self.config.estimated_velocity:
            return self._estimate[2] if self._estimate is not None else None
        return self.node.read(*self.key[name])

    @property
    def ready(self) -> bool:
        """The axis has seen a statusword, so its controlword can be decided safely."""
        return self.read('statusword') is not None

    @property
    def drive_state(self) -> DriveState:
        """The drive-independent state (unavailable while the node is not)."""
        return DriveState.UNAVAILABLE if not self.node.available else DRIVE_STATE[self.state]

    @property
    def state(self) -> State:
        statusword = self.read('statusword')
        return State.UNKNOWN if statusword is None else self.quirks.state_of(int(statusword))

    def update_config(self, config: AxisConfig) -> None:
        """A configuration with the units the family read at boot (scaling, limits)."""
        with self.lock:
            self.config = config
            self._stop_deceleration = None

    def _write(self, name: str, value: int | float) -> None:
        for output, out_value in self.quirks.outputs(name, value):
            self._write_object(output, out_value)

    def _write_object(self, name: str, value: int | float) -> None:
        key = self.key[name]
        if key in self.written or self.node.has_object(*key):
            self.put(key, value)

    def on_cycle(self, now: float) -> None:
        """Decide this cycle's controlword, mode and targets (cycle thread, non-blocking)."""
        statusword = self.read('statusword')
        if statusword is None:
            return
        statusword = int(statusword)
        state = self.quirks.state_of(statusword)
        if not self.node.available:  # sent to while its TPDOs are stale: the statusword is frozen
            self._hold_stale()
            return
        with self.lock:
            self._stale_hold = False
            self._notice_drop_out(state)
            command = self._device_command(state)
            mode_bits = self._mode_bits(state, statusword)
            controlword = command | mode_bits | (sm.CW_HALT if self.halted else 0)
            self._controlword = controlword
            mode = self._mode
            targets = self.quirks.cycle_targets(state, self._cycle_targets(state, now))
        self._write('mode', mode)
        for name, value in targets.items():
            self._write(name, value)
        self._write('controlword', controlword)
        if state is State.OPERATION_ENABLED and mode == Mode.INTERPOLATED_POSITION:
            if self.intents.feeder is not None:
                self.intents.feeder.on_cycle(now, self)
            elif self.intents.ip_point is not None:  # every cycle, even unchanged: one write is one point
                self.node.write(*self.key['ip_position'], self.intents.ip_point)

    def _hold_stale(self) -> None:
        """Inputs stale: the drive's real state is unknown, so only a controlword that cannot
        raise any state goes out (quick stop, HALT); the enable intent is dropped, so the
        axis moves again only after an explicit enable."""
        with self.lock:
            if not self._stale_hold:
                self._stale_hold = True
                self._target_state = None
                self.intents.drop()
                self.guard.forget()
                self.message = 'inputs stale: held by quick stop; enable it again to move'
                self.lock.notify_all()
            self._controlword = sm.CMD_QUICK_STOP | sm.CW_HALT
        self._write('controlword', self._controlword)

    def _notice_drop_out(self, state: State) -> None:
        """A drive that leaves operation enabled by itself (a fault, its enable input, a
        drive-side stop) is not walked back by the bridge: the enable intent is dropped and
        an explicit enable is needed."""
        if self._last_state is State.OPERATION_ENABLED and state is not State.OPERATION_ENABLED \
                and self._target_state is State.OPERATION_ENABLED:
            self._target_state = None
            self.message = f'left operation enabled by itself ({state.label}): enable it again to move'
        self._last_state = state

    def on_node_reset(self) -> None:
        """The node is configured again (it rebooted, or answers again after it was lost):
        every intent is dropped, and a drive still in operation enabled is disabled, so it is
        never re-enabled by itself."""
        with self.lock:
            self._target_state = None
            self._disable_on_return = True
            self._fault_reset_phase = 0
            self.intents.drop()
            self._pp_phase = PP_IDLE
            self.guard.forget()
            self.message = 'node configured again: enable the axis to move it'
            self.quirks.on_node_reset()
            self.lock.notify_all()

    def _device_command(self, state: State) -> int:
        hold = self.quirks.fault_hold(state)
        if hold is not None:  # the family's hold of a faulted drive, the reset bit's edge added
            if self._fault_reset_phase == 1:
                self._fault_reset_phase = 2
                return hold
            return hold | 1 << self._reset_bit if self._fault_reset_phase == 2 else hold
        if self._disable_on_return:
            if state is State.OPERATION_ENABLED and self._target_state is None:
                return sm.CMD_DISABLE_OPERATION
            self._disable_on_return = False
        if self._fault_reset_phase == 1:
            self._fault_reset_phase = 2
            return sm.hold_command(state)  # the reset bit low: its edge comes next
        if self._fault_reset_phase == 2:
            if state not in (State.FAULT, State.FAULT_REACTION_ACTIVE):
                self._fault_reset_phase = 0
            else:
                return 1 << self._reset_bit
        if self._target_state is None:
            return sm.hold_command(state)
        command = sm.next_command(state, self._target_state)
        return sm.hold_command(state) if command is None else command

    # -- intents (any thread but the CAN Notifier) -------------------------------------------
    def state_text(self) -> str:
        statusword = self.read('statusword')
        sw_text = 'no statusword received' if statusword is None else f'statusword 0x{int(statusword):04X}'
        return f'state {self.state.label}, {sw_text}'

    def fault_text(self) -> str:
        return self.faults.emcy_text()

    def _go_to(self, target: State, timeout: float | None) -> None:
        self.require_available()
        if self.state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            raise AxisError(f'{self.where()}: {self.fault_description()}')
        with self.lock:
            self._target_state = target
        wait = timeout if timeout is not None else self.timeouts.state_switch * 4

        def reached() -> bool:
            state = self.state
            if state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
                raise AxisError(f'{self.where()}: went to {state.label} while moving to '
                                f'{target.label}{self.fault_text()}')
            return state is target or (target is State.QUICK_STOP_ACTIVE and state is State.SWITCH_ON_DISABLED)
        self.wait(reached, wait, target.label)

    def enable(self, timeout: float | None = None) -> None:
        """Walk to OPERATION ENABLED (shutdown, switch on, enable operation)."""
        self._go_to(State.OPERATION_ENABLED, timeout)
        self._clear_refusal()

    def _clear_refusal(self) -> None:
        with self.lock:
            if self._setpoint_refused and self.message == self._setpoint_refused:
                self.message = ''
            self._setpoint_refused = ''

    def _quick_stop_from_cycle(self) -> None:
        """The cycle's own quick stop (a refused set-point): no wait, the cycle walks there."""
        self._target_state = State.QUICK_STOP_ACTIVE

    def disable(self, timeout: float | None = None) -> None:
        """Disable operation: SWITCHED ON, power stage kept (brake engages on most drives)."""
        self._go_to(State.SWITCHED_ON, timeout)

    def switch_off(self, timeout: float | None = None) -> None:
        """Disable voltage: SWITCH ON DISABLED."""
        self._go_to(State.SWITCH_ON_DISABLED, timeout)

    def quick_stop(self, timeout: float | None = None) -> None:
        """Quick stop: the drive ramps down with 0x6085, then (0x605A 0..4) disables."""
        self.require_available()
        with self.lock:
            self.intents.targets.clear()
            self.intents.source = None
        self._go_to(State.QUICK_STOP_ACTIVE, timeout)

    def halt(self, on: bool = True) -> None:
        """The controlword HALT bit (8): the drive decelerates and stays enabled. Released in
        IP with no stream feeding the drive, its buffer is cleared first: points left queued
        (a stream aborted by a buffer fault) would otherwise run on their own."""
        self.require_available()
        if not on and self.halted:
            self._clear_unfed_buffer()
        with self.lock:
            self.halted = on
            if on:
                self.intents.source = None
        if not on:
            self._clear_refusal()

    def reset_fault(self, timeout: float | None = None) -> None:
        """Fault reset the family's way (the rising edge of bit 7); fails if the fault persists."""
        self.require_available()
        if self.state not in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            return
        self.quirks.reset_fault(timeout)

    def reset_by_edge(self, bit: int, timeout: float | None, done: Callable[[], bool] | None = None,
                      what: str = 'fault reset (leaving FAULT)',
                      failed: Callable[[], str] = lambda: 'the cause is still present') -> None:
        """A rising edge of controlword ``bit``, then a wait until ``done()`` (the state left FAULT)."""
        with self.lock:
            self._target_state = State.SWITCH_ON_DISABLED
            self._reset_bit = bit
            self._fault_reset_phase = 1
        wait = timeout if timeout is not None else self.timeouts.state_switch
        try:
            self.wait(done or (lambda: self.state not in (State.FAULT, State.FAULT_REACTION_ACTIVE)), wait, what)
        except AxisError as exc:
            with self.lock:
                self._fault_reset_phase = 0
            raise AxisError(f'{exc}; {failed()}{self.fault_text()}') from None
        self.faults.mark_reset()

    def on_booted(self) -> str:
        """After each boot (boot thread): settle the mode (0x6502) and the limits (the drive's
        own where the config gives none); the start-up lines, the limits only when they changed."""
        lines = [self._settle_mode()]
        try:
            limits = with_drive_limits(self.node, self.config, self._configured_limits)
        except DriveBridgeError as exc:
            limits = self._configured_limits
            lines.append(f'{self.where()}: drive limits not read ({exc}); the configured ones apply')
        with self.lock:
            self.config = replace(self.config, limits=limits)
            self.loop = None  # rebuilt with these limits
            self._stop_deceleration = None
        said = describe(self.joint, limits)
        if said != self._limits_said:
            self._limits_said = said
            lines.append(said)
        return '; '.join(line for line in lines if line)

    def fault_description(self) -> str:
        return self.faults.description()

    def way_out(self) -> str:
        if self.state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            return self.fault_description()
        return 'enable it first (~/enable)'

    # -- state ------------------------------------------------------------------------------
    def last_emcy(self) -> EmcyEvent | None:
        return self.faults.last_emcy()

    def feedback(self) -> tuple[bool, float, float, float, float]:
        """(available, position, velocity, effort, stamp) in SI: the cheap path for joint states."""
        scaling = self.config.scaling
        position, velocity, torque = (self.read(k) for k in ('position', 'velocity', 'torque'))
        return (self.node.available and position is not None,
                scaling.position_to_si(position) if position is not None else math.nan,
                scaling.velocity_to_si(velocity) if velocity is not None else math.nan,
                scaling.effort_to_si(torque) if torque is not None else math.nan,
                self.node.stamp(*self.key['position']))

    def state_key(self) -> tuple[object, ...]:
        return (self.node.available, self.read('statusword'), self.read('mode_display'), self._controlword,
                self.deadman.stale, self.halted, self.message, self._mode_problem, self.quirks.fault_pending())

    def snapshot(self) -> AxisSnapshot:
        statusword = self.read('statusword')
        sw = int(statusword) if statusword is not None else 0
        _available, position, velocity, effort, stamp = self.feedback()
        mode = int(self.read('mode_display') or 0)
        available = self.node.available and statusword is not None
        return self.snapshot_of(
            available=available,
            drive_state=self.drive_state if statusword is not None else DriveState.UNAVAILABLE,
            state=self.state, statusword=sw, controlword=self._controlword,
            mode=mode, mode_name=mode_name(mode), requested_mode=self._mode,
            position=position, velocity=velocity, effort=effort, stamp=stamp,
            fault=bool(sw & sm.SW_FAULT) or (available and self.quirks.fault_pending()),
            warning=bool(sw & sm.SW_WARNING),
            target_reached=bool(sw & sm.SW_TARGET_REACHED), internal_limit=bool(sw & sm.SW_INTERNAL_LIMIT),
            following_error=(bool(sw & sm.SW_OMS_13)
                             and self._mode in (Mode.PROFILE_POSITION, Mode.CYCLIC_SYNC_POSITION)),
            setpoint_refused=self._setpoint_refused,
            message=(self.node.boot_error if not self.node.available and self.node.boot_error else '')
            or self.message or self._mode_problem or (
                'velocity estimated from position (no PDO carries 0x606C)' if self.config.estimated_velocity else ''))
