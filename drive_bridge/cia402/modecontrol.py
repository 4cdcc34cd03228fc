"""Per-mode control of a CiA 402 axis: what each mode of operation adds to the controlword
and writes as targets, decided each cycle, and the mode intents (set_mode, command, home);
trajectory streaming is :class:`~drive_bridge.cia402.streamcontrol.StreamControl`'s. A mixin
of :class:`~drive_bridge.cia402.axis.Axis`, which drives the state machine and owns the state
these methods share.
"""
from __future__ import annotations

import time
from dataclasses import replace

from drive_bridge.cia402 import bootmodes, statemachine as sm
from drive_bridge.cia402.errors import AxisError, SetpointRefused
from drive_bridge.cia402.homing import write_homing_parameters
from drive_bridge.cia402.modes import (
    CYCLIC_MODES,
    POSITION_MODES,
    TORQUE_MODES,
    VELOCITY_MODES,
    Mode,
    mode_name,
)
from drive_bridge.cia402.modesupport import ModeSupport
from drive_bridge.cia402.setpoint_check import check_targets, seed_hold
from drive_bridge.cia402.statemachine import State
from drive_bridge.cia402.streamcontrol import StreamControl
from drive_bridge.joint import Setpoint
from drive_bridge.joint.position_loop import PositionLoop
from drive_bridge.joint.strategy import StreamStrategy
from drive_bridge.model import PositionLoopConfig

PP_IDLE, PP_STAGED, PP_EDGE, PP_RELEASE = range(4)
AUTO_LOOP = PositionLoopConfig(gain=10.0)  # 1/s: the loop of an axis put in pv at boot without one


class ModeControl(StreamControl):
    """Modes of operation of one axis: profile position handshake, homing, interpolated
    position (linear and the family's PVT), cyclic set-points with the command dead-man."""

    # shared with the state-machine driver (set in Axis.__init__)
    modes: ModeSupport
    _pp_phase: int
    _pp_done: float
    _homing: bool

    def fault_text(self) -> str:  # provided by the state-machine driver
        raise NotImplementedError

    # -- each cycle -------------------------------------------------------------------------
    def _mode_bits(self, state: State, statusword: int) -> int:
        if state is not State.OPERATION_ENABLED:
            return 0
        mode = int(self.read('mode_display') or 0)
        if mode == Mode.PROFILE_POSITION and self._pp_phase:
            return self._pp_handshake(statusword)
        if mode == Mode.HOMING and self._homing:
            return sm.CW_OMS_4
        if mode == Mode.INTERPOLATED_POSITION and (self.intents.source is not None or self.intents.feeder is not None):
            return sm.CW_OMS_4  # interpolation enabled while a stream feeds the drive
        return 0

    def _pp_handshake(self, statusword: int) -> int:
        """Profile position set-point handshake, one step per cycle. The target goes out one
        cycle before the bit 4 edge, so a drive applying RPDOs in COB-ID order at SYNC
        (controlword first) still latches the new target."""
        if self._pp_phase == PP_STAGED:
            self._pp_phase = PP_EDGE
            return 0
        if self._pp_phase == PP_EDGE:
            if statusword & sm.SW_OMS_12:  # acknowledged: drop bit 4
                self._pp_phase = PP_RELEASE
                return 0
            return sm.CW_OMS_4 | sm.CW_OMS_5  # new set-point, change immediately
        if not statusword & sm.SW_OMS_12:  # the drive dropped its acknowledge: done
            self._pp_phase = PP_IDLE
            self._pp_done = self.node.stamp(*self.key['statusword'])
        return 0

    def _looped(self) -> bool:
        return self.stream_strategy() == StreamStrategy.POSITION_LOOP

    def _cycle_targets(self, state: State, now: float) -> dict[str, int]:
        mode = self._mode
        actual = self.read('position')
        idle = not self.intents.targets and self.intents.source is None and self.intents.loop_target is None
        if state is not State.OPERATION_ENABLED or idle:
            # follow the actual position until commanded: enabling never jumps
            hold = {'target_velocity': 0, 'target_torque': 0}
            if actual is not None and mode != Mode.PROFILE_POSITION:
                hold['target_position'] = int(actual)
            if state is not State.OPERATION_ENABLED:  # commands never survive a drop-out
                self.intents.drop()
                self.deadman.stale = False
            written = hold if not self.intents.targets else {**hold, **self.intents.targets}
            seed_hold(self.guard, self.config, written, now)
            return written
        if self.intents.source is not None:
            setpoint = self.intents.source(now)
            if setpoint is not None:
                self._apply_setpoint(setpoint)
        looped = self.intents.loop_target is not None and self._looped()
        stale = self.deadman.stale
        if (mode in CYCLIC_MODES or looped) and self.deadman.expired(self.timeouts.command_timeout):
            self.message = (f'no command for {self.timeouts.command_timeout * 1000:.0f} ms in '
                            f'{mode_name(mode)}: holding position')
            self.intents.targets = {'target_velocity': 0, 'target_torque': 0}
            if looped and self.intents.loop_target is not None:  # the loop holds the last desired position
                self.intents.loop_target = (self.intents.loop_target[0], 0.0)
            elif actual is not None:
                self.intents.targets['target_position'] = int(actual)
        if looped and actual is not None:
            self._close_loop(actual)
        if self.deadman.stale and not stale:  # the dead-man holds where the drive is: no step to check
            seed_hold(self.guard, self.config, self.intents.targets, now)
        else:
            intents = self.intents
            problem = check_targets(self.guard, self.config, mode, looped, intents.targets, intents.ip_point, now)
            if problem is not None:
                self._refuse_setpoint(problem, actual)
        return dict(self.intents.targets)

    def _close_loop(self, actual: int | float) -> None:
        """One step of the bridge's position loop: 0x60FF from the desired state and the
        measured position; beyond the following-error limit a trajectory stream stops with HALT."""
        assert self.intents.loop_target is not None
        if self.loop is None:
            self.loop = PositionLoop(self.config.position_loop, self.config.limits)
        scaling = self.config.scaling
        velocity = self.loop_velocity(scaling.position_to_si(actual), 'HALT', abs(scaling.position_factor))
        self.intents.targets['target_velocity'] = 0 if velocity is None else scaling.velocity_to_device(velocity)

    def _apply_setpoint(self, setpoint: Setpoint) -> None:
        refusal = self.quirks.setpoint_refusal(setpoint)
        if refusal:  # never sent: the stream stops, the axis holds its last set-point (HALT)
            self.intents.source = None
            self.halted = True
            self.message = refusal
            return
        scaling = self.config.scaling
        if setpoint.position is not None and self._looped():
            self.follow_position(setpoint.position, setpoint.velocity, self._actual_velocity())
            return
        if setpoint.position is not None and self._mode == Mode.INTERPOLATED_POSITION:
            self.intents.ip_point = scaling.position_to_device(setpoint.position)
        elif setpoint.position is not None:
            self.intents.targets['target_position'] = scaling.position_to_device(setpoint.position)
        if setpoint.velocity is not None:
            self.intents.targets['target_velocity'] = scaling.velocity_to_device(setpoint.velocity)
        if setpoint.effort is not None:
            self.intents.targets['target_torque'] = scaling.effort_to_device(setpoint.effort)
        self.deadman.last = time.monotonic()
        self.deadman.stale = False

    def _settle_mode(self) -> str:
        """After each boot of the node (boot thread): read 0x6502 and settle the axis' mode (the
        configured one, or the best the drive can stream when the config names none); returns
        the start-up line saying which and why ('' when the family decides the modes)."""
        auto = self.config.auto_mode
        if auto is None and self.modes.accepted is not None:
            return ''  # the family knows the drive's modes better than its 0x6502
        supported, inferred = self.modes.read(), False
        if supported is None and auto is not None and auto.inferred_support is not None:
            supported, inferred = auto.inferred_support, True
        chosen = bootmodes.pick(self.config.mode, auto, supported, inferred)
        if auto is not None and chosen.mode in (Mode.INTERPOLATED_POSITION, Mode.CYCLIC_SYNC_POSITION):
            self.interpolation.write_period(chosen.mode == Mode.INTERPOLATED_POSITION, self.config.ip_submode)
        with self.lock:
            self.modes.supported = None if inferred else supported
            self._mode_problem = chosen.problem
            if auto is not None and not chosen.problem and chosen.mode != self._mode:
                looped = chosen.mode in VELOCITY_MODES
                loop = self.config.position_loop if self.config.position_loop.enabled or not looped else AUTO_LOOP
                self.config = replace(self.config, mode=chosen.mode, position_mode=chosen.mode, position_loop=loop)
                self._mode = chosen.mode
                self.intents.targets.clear()
                self.intents.source = None
        return f'{self.where()}: {chosen.problem or chosen.note}'

    def set_mode(self, mode: int | str, timeout: float | None = None) -> None:
        """Write 0x6060 and wait until 0x6061 confirms it."""
        self.require_available()
        code = self.quirks.parse_mode(mode)
        self.modes.check(code, self.where())
        if not self.quirks.before_mode_change(code):
            return
        if code == Mode.INTERPOLATED_POSITION:
            self.interpolation.prepare(self.config.ip_submode)
        previous = self._mode
        self._request_mode(code)
        wait = timeout if timeout is not None else self.timeouts.mode_switch
        try:
            self.wait(lambda: self.read('mode_display') == code, wait, f'mode {mode_name(code)} (0x6061)')
        except AxisError as exc:
            raise AxisError(f'{exc}; {self._restore_mode(previous, code)}') from None
        self._mode_problem = ''  # the drive took it

    def _request_mode(self, code: int) -> None:
        with self.lock:
            if code != self._mode:
                self.intents.drop()
                self._pp_phase = PP_IDLE
            self._mode = code

    def _restore_mode(self, previous: int, refused: int) -> str:
        """A mode the drive did not confirm: the previous one is requested again; if the drive
        does not confirm that either, the axis is halted (the mode it runs is unknown)."""
        self._request_mode(previous)
        try:
            self.wait(lambda: self.read('mode_display') == previous, self.timeouts.mode_switch,
                       f'previous mode {mode_name(previous)} (0x6061)')
        except AxisError:
            with self.lock:
                self.halted = True
                self.message = (f'mode {mode_name(refused)} not confirmed and the previous mode '
                                f'{mode_name(previous)} not either (0x6061 = {self.read("mode_display")}): '
                                'axis held (HALT)')
            return f'the previous mode {mode_name(previous)} was not confirmed either: axis held (HALT)'
        return f'the previous mode {mode_name(previous)} is restored'

    def command_field(self) -> str | None:
        """Which value a direct command of the current mode carries: position, velocity or effort."""
        return self.quirks.command_field(self._mode)

    def _actual_velocity(self) -> float:
        value = self.read('velocity')
        return self.config.scaling.velocity_to_si(value) if value is not None else 0.0

    @property
    def mode(self) -> int:
        """The mode the bridge requests (0x6060)."""
        return self._mode

    def check_command(self, position: float | None = None, velocity: float | None = None,
                      effort: float | None = None) -> None:
        """Raise AxisError if this command cannot be applied now (limits, mode, state)."""
        if self.quirks.check_command(position, velocity, effort):
            return
        self._require_mode()
        self.check_limits(position, velocity, effort)
        mode = self._mode
        if position is not None and mode not in POSITION_MODES and not self._looped():
            raise AxisError(f'{self.where()}: a position command needs a position mode; mode is {mode_name(mode)}')
        if velocity is not None and mode not in VELOCITY_MODES and mode != Mode.CYCLIC_SYNC_POSITION:
            raise AxisError(f'{self.where()}: a velocity command needs a velocity mode; mode is {mode_name(mode)}')
        if effort is not None and mode not in TORQUE_MODES and mode not in CYCLIC_MODES:
            raise AxisError(f'{self.where()}: an effort command needs a torque mode; mode is {mode_name(mode)}')
        self.require_alive()
        if self.state is not State.OPERATION_ENABLED:
            raise AxisError(f'{self.where()}: {self.state.label}, not operation enabled; {self.way_out()}')
        try:
            self._check_step(position, velocity)
        except SetpointRefused as exc:
            raise AxisError(str(exc)) from None

    def command(self, position: float | None = None, velocity: float | None = None,
                effort: float | None = None) -> None:
        """Set targets in SI for the current mode (non-blocking; sent on the next cycle).

        In profile position mode a new position starts a set-point handshake. In cyclic
        modes commands feed the dead-man: if they stop for ``command_timeout`` the axis holds.
        """
        self.check_command(position, velocity, effort)
        mode = self._mode
        with self.lock:
            self.intents.source = None
            self._apply_setpoint(Setpoint(position, velocity if mode in VELOCITY_MODES else None,
                                          effort if mode in TORQUE_MODES else None))
            if mode == Mode.PROFILE_POSITION and position is not None:
                self._pp_phase = PP_STAGED
            if mode not in CYCLIC_MODES and not self._looped():
                self.deadman.last = 0.0  # profile modes keep their target: no dead-man

    def home(self, timeout: float | None = None) -> None:
        """Run the drive's homing (0x6098 method etc. from the config, else the drive's own)."""
        self.require_available()
        if self.state is not State.OPERATION_ENABLED:
            raise AxisError(f'{self.where()}: enable the axis before homing (state {self.state.label})')
        previous = self._mode
        write_homing_parameters(self.node, self.config)
        self.set_mode(Mode.HOMING)
        wait = timeout if timeout is not None else self.timeouts.homing
        with self.lock:
            self._homing = True

        def finished() -> bool:
            statusword = int(self.read('statusword') or 0)
            if statusword & sm.SW_OMS_13:
                raise AxisError(f'{self.where()}: the drive reports a homing error (statusword 0x{statusword:04X})')
            if self.state is not State.OPERATION_ENABLED:
                raise AxisError(f'{self.where()}: left operation enabled during homing '
                                f'({self.state.label}){self.fault_text()}')
            return bool(statusword & sm.SW_OMS_12 and statusword & sm.SW_TARGET_REACHED)
        try:
            self.wait(finished, wait, 'homing attained')
        finally:
            with self.lock:
                self._homing = False
        if previous != Mode.HOMING:
            self.set_mode(previous)

    def wait_target_reached(self, timeout: float) -> None:
        """Wait for statusword bit 10 received after the PP set-point handshake completed."""
        def reached() -> bool:
            statusword = int(self.read('statusword') or 0)
            return (self._pp_phase == PP_IDLE and bool(statusword & sm.SW_TARGET_REACHED)
                    and self.node.stamp(*self.key['statusword']) > self._pp_done)
        self.wait(reached, timeout, 'target reached')
