"""The device control of a simulated CiA 402 axis: the state machine (CiA 402 §6.3) driven by
the controlword's device control commands, the stop ramps of halt, quick stop, disable
operation, shutdown and the fault reaction, and the statusword that shows them.

Choices where CiA 402 leaves room (a master must cope with all of them on real drives):

- A device control command with bit 7 set is not evaluated outside Fault (bit 7 is
  "fault reset"; a master must drop it before sending shutdown).
- Fault reset acts on the rising edge of bit 7 only (the axis decides whether the cause
  persists).
- Transitions 5 and 8 with option code 1 (0x605C / 0x605B) ramp down in Operation
  Enabled first, then switch; a ramp is the slow-down ramp 0x6084, the quick-stop
  ramp 0x6085, or for "current/voltage limit" (3, 4, 7, 8) the max deceleration 0x60C6.
- Quick stop option codes outside 0..8 behave as 2; halt option 0 behaves as 1.
- A stop ramp starts from the demand, or from the actual motion when the two differ
  by more than the following error window (after a set-point jump).
"""
from __future__ import annotations

from typing import Any, Protocol

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.statemachine import (
    CW_ENABLE_OPERATION,
    CW_ENABLE_VOLTAGE,
    CW_FAULT_RESET,
    CW_HALT,
    CW_QUICK_STOP,
    CW_SWITCH_ON,
    SW_INTERNAL_LIMIT,
    SW_REMOTE,
    SW_TARGET_REACHED,
    SW_VOLTAGE_ENABLED,
    SW_WARNING,
    State,
    statusword_bits_for,
)
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.opmode import OpMode

ENERGISED = frozenset({State.OPERATION_ENABLED, State.QUICK_STOP_ACTIVE, State.FAULT_REACTION_ACTIVE})
VOLTAGE_STATES = frozenset({State.READY_TO_SWITCH_ON, State.SWITCHED_ON, *ENERGISED})


class StopRamp:
    """A running stop ramp and what follows it."""

    __slots__ = ('reason', 'deceleration', 'then', 'finished', 'settling')

    def __init__(self, reason: str, deceleration: float, then: State | None) -> None:
        self.reason = reason  # halt, quick_stop, fault, disable_operation, shutdown
        self.deceleration = max(deceleration, 1.0)
        self.then = then  # state entered when stopped (None: stay)
        self.finished = False
        self.settling = 0.0  # s the demand has stood still while the motor settles


class ControlledAxis(ModeAxis, Protocol):
    """The axis as its device control sees it: its state, its mode, its hooks."""

    state: State
    mode_impl: OpMode

    def motion_parameters(self) -> dict[str, Any]: ...

    def enter_mode(self) -> None: ...

    def acknowledge_fault(self) -> bool: ...

    def restart_following_error(self) -> None: ...

    def on_transition(self, old: State, new: State) -> None: ...


class DeviceControl:
    """The state machine of one axis; ``stop`` is the running (or finished, still holding) ramp."""

    def __init__(self, axis: ControlledAxis) -> None:
        self._axis = axis
        self.stop: StopRamp | None = None

    def on_controlword(self, prev: int, cw: int) -> None:
        """0x6040 changed from ``prev`` to ``cw``: the device control commands and the mode's bits."""
        state = self._axis.state
        if state is State.FAULT:
            if cw & CW_FAULT_RESET and not prev & CW_FAULT_RESET:
                self._axis.acknowledge_fault()
            return
        if state in (State.FAULT_REACTION_ACTIVE, State.NOT_READY_TO_SWITCH_ON) or cw & CW_FAULT_RESET:
            return
        disable_voltage = not cw & CW_ENABLE_VOLTAGE
        quick_stop = not disable_voltage and not cw & CW_QUICK_STOP
        low = cw & (CW_SWITCH_ON | CW_ENABLE_VOLTAGE | CW_QUICK_STOP | CW_ENABLE_OPERATION)
        shutdown = low & 0x07 == 0x06
        switch_on = low == 0x07
        enable = low == 0x0F
        if state is State.SWITCH_ON_DISABLED:
            if shutdown:
                self.goto(State.READY_TO_SWITCH_ON)  # 2
        elif state is State.READY_TO_SWITCH_ON:
            if disable_voltage or quick_stop:
                self.goto(State.SWITCH_ON_DISABLED)  # 7
            elif switch_on:
                self.goto(State.SWITCHED_ON)  # 3
            elif enable:
                self.goto(State.SWITCHED_ON)  # 3 + 4
                self.goto(State.OPERATION_ENABLED)
        elif state is State.SWITCHED_ON:
            if disable_voltage or quick_stop:
                self.goto(State.SWITCH_ON_DISABLED)  # 10
            elif shutdown:
                self.goto(State.READY_TO_SWITCH_ON)  # 6
            elif enable:
                self.goto(State.OPERATION_ENABLED)  # 4
        elif state is State.OPERATION_ENABLED:
            self._in_operation_enabled(prev, cw, disable_voltage, quick_stop, shutdown, switch_on, enable)
        elif state is State.QUICK_STOP_ACTIVE:
            if disable_voltage:
                self.goto(State.SWITCH_ON_DISABLED)  # 12
            elif enable and self._quick_stop_option() >= 5:
                self.goto(State.OPERATION_ENABLED)  # 16

    def _in_operation_enabled(self, prev: int, cw: int, disable_voltage: bool, quick_stop: bool,
                              shutdown: bool, switch_on: bool, enable: bool) -> None:
        ax = self._axis
        pending = self.stop is not None and self.stop.reason in ('disable_operation', 'shutdown')
        if disable_voltage:
            self.goto(State.SWITCH_ON_DISABLED)  # 9
        elif quick_stop:
            self._quick_stop()  # 11
        elif shutdown and not pending:
            self._ramp_or_go(ax.param(obj.SHUTDOWN_OPTION, default=0), 'shutdown', State.READY_TO_SWITCH_ON)  # 8
        elif switch_on and not pending:
            self._ramp_or_go(ax.param(obj.DISABLE_OPERATION_OPTION, default=0), 'disable_operation',
                             State.SWITCHED_ON)  # 5
        elif enable:
            if pending:  # enable operation again during a disable ramp: keep running
                self.stop = None
                ax.enter_mode()
            self._update_halt(cw)
            if self.stop is None and ax.state is State.OPERATION_ENABLED:
                ax.mode_impl.on_controlword(ax, prev, cw)

    def _update_halt(self, cw: int) -> None:
        ax = self._axis
        halt = bool(cw & CW_HALT)
        if halt == ax.halted:
            return
        ax.halted = halt
        if halt:
            option = ax.param(obj.HALT_OPTION, default=1)
            self.begin_stop(StopRamp('halt', self.ramp_deceleration(option if option in (1, 2, 3, 4) else 1), None))
        elif self.stop is not None and self.stop.reason == 'halt':
            self.stop = None
            ax.mode_impl.resume(ax)

    def begin_stop(self, stop: StopRamp) -> None:
        """Start a stop ramp from the demand, or from the motor's actual motion when the two
        have parted (beyond the following error window): brake the motor, not a set-point
        it never reached."""
        ax = self._axis
        window = ax.motion_parameters()['fe_window']
        if window != 0xFFFFFFFF and abs(ax.dp - ax.p) > window:
            ax.dp, ax.dv = ax.p, ax.v
        self.stop = stop

    def _ramp_or_go(self, option: int, reason: str, then: State) -> None:
        if option == 1:
            self.begin_stop(StopRamp(reason, self.ramp_deceleration(1), then))
        else:
            self.goto(then)

    def _quick_stop_option(self) -> int:
        option = self._axis.param(obj.QUICK_STOP_OPTION, default=2)
        return option if 0 <= option <= 8 else 2

    def _quick_stop(self) -> None:
        option = self._quick_stop_option()
        self.goto(State.QUICK_STOP_ACTIVE)
        if option == 0:
            self.goto(State.SWITCH_ON_DISABLED)  # disable drive function: coast, 12 at once
            return
        kind = option if option <= 4 else option - 4
        self.begin_stop(StopRamp('quick_stop', self.ramp_deceleration(kind),
                                 State.SWITCH_ON_DISABLED if option <= 4 else None))

    def ramp_deceleration(self, kind: int) -> float:
        """1 slow-down ramp, 2 quick-stop ramp, 3/4 current/voltage limit (max deceleration)."""
        parameters = self._axis.motion_parameters()
        if kind == 1:
            return parameters['deceleration']
        if kind == 2:
            return parameters['quick_stop_deceleration']
        return parameters['max_deceleration']

    def fault_reaction(self) -> None:
        """A fault occurred: Fault Reaction Active, then Fault after the ramp of 0x605E."""
        ax = self._axis
        option = ax.param(obj.FAULT_REACTION_OPTION, default=2)
        energised = ax.state in ENERGISED
        self.goto(State.FAULT_REACTION_ACTIVE)
        if not energised or option == 0 or not 0 <= option <= 4:
            self.goto(State.FAULT)  # nothing to stop, or coast
            return
        self.begin_stop(StopRamp('fault', self.ramp_deceleration(option), State.FAULT))

    def statusword(self, internal_limit: bool) -> int:
        """0x6041 now: the state's bits, voltage enabled (bit 4) from Ready to Switch On up to
        Fault Reaction Active, remote (bit 9) always, warning (bit 7) after an IP buffer
        overflow, the mode's bits, target reached at standstill while halted or in Quick Stop
        Active, and ``internal_limit`` (bit 11)."""
        ax = self._axis
        state = ax.state
        sw = statusword_bits_for(state) | SW_REMOTE
        if state in VOLTAGE_STATES:
            sw |= SW_VOLTAGE_ENABLED
        if ax.ip.overflows:
            sw |= SW_WARNING
        if state is State.OPERATION_ENABLED:
            if ax.halted or (self.stop is not None and self.stop.reason == 'halt'):
                sw |= ax.mode_impl.status_bits(ax) & ~SW_TARGET_REACHED
                if ax.standstill():
                    sw |= SW_TARGET_REACHED
            else:
                sw |= ax.mode_impl.status_bits(ax)
        elif state is State.QUICK_STOP_ACTIVE and ax.standstill():
            sw |= SW_TARGET_REACHED
        if internal_limit:
            sw |= SW_INTERNAL_LIMIT
        return sw

    def goto(self, state: State) -> None:
        """Enter ``state`` with the transition's effects, then the axis' ``on_transition``."""
        ax = self._axis
        old, ax.state = ax.state, state
        if state is State.OPERATION_ENABLED:
            self.stop = None
            ax.halted = bool(ax.controlword & CW_HALT)
            if old is not State.QUICK_STOP_ACTIVE:
                ax.dp, ax.dv = ax.p, ax.v
            ax.enter_mode()
            if ax.halted:
                ax.halted = False
                self._update_halt(ax.controlword)
            ax.restart_following_error()
        elif state not in ENERGISED:
            self.stop = None
            ax.halted = False
        ax.on_transition(old, state)

    def release(self) -> None:
        """End the stop ramp: in Operation Enabled the mode starts again from the present demand."""
        if self.stop is not None:
            self.stop = None
            if self._axis.state is State.OPERATION_ENABLED:
                self._axis.enter_mode()

    def settle(self, dt: float, standstill: float, settle_max: float) -> None:
        """After a model step: a ramp whose demand stands still ends once the motor, not only the
        demand, stands still (below ``standstill``) or after ``settle_max`` s, and enters its
        next state."""
        stop, ax = self.stop, self._axis
        if stop is not None and not stop.finished and ax.dv == 0.0:
            stop.settling += dt
            if abs(ax.v) < standstill or stop.settling > settle_max:
                stop.finished = True
                if stop.then is not None:
                    self.goto(stop.then)
