"""CiA 402 state transitions per axis (statusword from TPDOs or SDO) and controlwords that
did not lead where they should (the state machine of drive_bridge.cia402.statemachine)."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

from drive_bridge.bag.diagnose.emcy import EmcyTimeline
from drive_bridge.bag.diagnose.model import Context, Severity
from drive_bridge.cia402.modes import mode_name
from drive_bridge.cia402.statemachine import (
    CMD_ENABLE_OPERATION,
    CMD_SHUTDOWN,
    CMD_SWITCH_ON,
    CW_FAULT_RESET,
    State,
    state_from_statusword,
)

MODE_SWITCH_S = 1.0  # as Timeouts.mode_switch
STATE_SWITCH_S = 1.0  # as Timeouts.state_switch: a command not followed this long did not work
EMCY_BEFORE_S = 1.0  # an EMCY this long before a Fault is its cause ...
EMCY_AFTER_S = 0.5  # ... or this long after it (drives send the statusword first, then the EMCY)
_REACHABLE = {  # CiA 402-2 §8.1 transitions a command can take from a state
    CMD_SHUTDOWN: {State.SWITCH_ON_DISABLED, State.SWITCHED_ON, State.OPERATION_ENABLED,
                   State.READY_TO_SWITCH_ON},
    CMD_SWITCH_ON: {State.READY_TO_SWITCH_ON, State.OPERATION_ENABLED, State.SWITCHED_ON},
    CMD_ENABLE_OPERATION: {State.SWITCHED_ON, State.READY_TO_SWITCH_ON, State.QUICK_STOP_ACTIVE,
                           State.OPERATION_ENABLED},
}


def command_of(controlword: int) -> tuple[str, set[State]]:
    """(name, states it should lead to) for a controlword's device control command."""
    if controlword & 0x02 == 0:
        return 'disable voltage', {State.SWITCH_ON_DISABLED}
    if controlword & 0x06 == 0x02:
        return 'quick stop', {State.QUICK_STOP_ACTIVE, State.SWITCH_ON_DISABLED}
    if controlword & 0x87 == 0x06:
        return 'shutdown', {State.READY_TO_SWITCH_ON}
    if controlword & 0x8F == 0x07:
        return 'switch on', {State.SWITCHED_ON}
    if controlword & 0x8F == 0x0F:
        return 'enable operation', {State.OPERATION_ENABLED}
    return 'fault reset', {State.SWITCH_ON_DISABLED}


@dataclass
class Command:
    time: float
    controlword: int
    name: str
    expected: set[State]
    from_state: State
    observed: bool = False  # a statusword arrived after it


@dataclass
class AxisTrack:
    node: int
    slot: int
    state: State = State.UNKNOWN
    statusword: int | None = None
    controlword: int | None = None
    transitions: list[tuple[float, State, State]] = field(default_factory=list)  # relative t
    seqs: list[int] = field(default_factory=list)  # each transition's event sequence number
    pending: Command | None = None
    failed: int = 0
    commands: int = 0
    mode_requested: tuple[float, int] | None = None  # (time, 0x6060) not yet echoed by 0x6061
    mode_display: int | None = None
    modes: list[tuple[float, int]] = field(default_factory=list)  # 0x6061 changes, relative t


class Cia402Axes:
    def __init__(self, ctx: Context, emcy: EmcyTimeline) -> None:
        self.ctx = ctx
        self.emcy = emcy
        self.axes: dict[tuple[int, int], AxisTrack] = {}
        self._uncaused: list[tuple[int, int, float, int]] = []  # (finding index, node, t relative, EMCY count)

    def _axis(self, node: int, slot: int) -> AxisTrack:
        axis = self.axes.get((node, slot))
        if axis is None:
            axis = self.axes[(node, slot)] = AxisTrack(node, slot)
        return axis

    def statusword(self, t: float, node: int, slot: int, value: int) -> None:
        axis = self.axes.get((node, slot)) or self._axis(node, slot)
        pending = axis.pending
        if value == axis.statusword:
            if pending is not None:
                pending.observed = True
                if t - pending.time > STATE_SWITCH_S and self.ctx.timing:
                    self._failed(axis, pending)
            return
        axis.statusword = value
        state = state_from_statusword(value)
        if pending is not None:
            pending.observed = True
            if state in pending.expected:
                axis.pending = None
            elif t - pending.time > STATE_SWITCH_S and self.ctx.timing:
                self._failed(axis, pending)
        if state is axis.state:
            return
        self.ctx.events += 1
        axis.transitions.append((t - self.ctx.t0, axis.state, state))
        axis.seqs.append(self.ctx.events)
        previous, axis.state = axis.state, state
        if state is State.FAULT and previous is not State.FAULT_REACTION_ACTIVE or \
                state is State.FAULT_REACTION_ACTIVE:
            fault = self.emcy.fault_before(node, t, EMCY_BEFORE_S)
            what = (f'axis {slot + 1}: in {state.label} at its first statusword (0x{value:04X})'
                    if previous is State.UNKNOWN else f'axis {slot + 1}: {previous.label} -> {state.label}')
            cause = '' if fault is None else fault.text + (f' at t={fault.time:.3f} s' if self.ctx.timing
                                                           else ' before it')
            self.ctx.add(Severity.ERROR, t, node, what, cause, 'cia402-fault', slot=slot,
                         short=f'node {node} axis {slot + 1} in Fault' + (f' (EMCY 0x{fault.event.code:04X})'
                                                                           if fault is not None else ''))
            if fault is None:
                self._uncaused.append((len(self.ctx.findings) - 1, node, t - self.ctx.t0, len(self.emcy.records)))

    def controlword(self, t: float, node: int, slot: int, value: int) -> None:
        axis = self.axes.get((node, slot)) or self._axis(node, slot)
        previous = axis.controlword
        axis.controlword = value
        if previous is not None and (previous & 0x8F) == (value & 0x8F):
            return
        if value & CW_FAULT_RESET and previous is not None and previous & CW_FAULT_RESET:
            return  # the reset acts on the edge only
        name, expected = command_of(value)
        if axis.pending is not None and axis.pending.observed and t - axis.pending.time > STATE_SWITCH_S \
                and self.ctx.timing:
            self._failed(axis, axis.pending)
        axis.commands += 1
        # In Fault only a fault reset leads anywhere (CiA 402 transition 15): any other command
        # (a master disabling the axis after the fault) is expected to leave it there.
        in_fault = axis.state is State.FAULT and name != 'fault reset'
        axis.pending = None if axis.state in expected or in_fault else Command(t, value, name, expected, axis.state)

    def _failed(self, axis: AxisTrack, command: Command) -> None:
        axis.pending = None
        axis.failed += 1
        wanted = ' or '.join(sorted(s.label for s in command.expected))
        if axis.state is State.FAULT and command.name != 'fault reset':
            cause = 'the drive is in Fault: reset it first (controlword bit 7 rising edge)'
        elif command.name in ('shutdown', 'switch on', 'enable operation') and \
                command.from_state not in _REACHABLE[{'shutdown': CMD_SHUTDOWN, 'switch on': CMD_SWITCH_ON,
                                                      'enable operation': CMD_ENABLE_OPERATION}[command.name]]:
            cause = (f'no such transition from {command.from_state.label} (CiA 402): '
                     'the command skips a step (shutdown 0x06 comes first)')
        elif axis.state is State.SWITCH_ON_DISABLED and command.name != 'disable voltage':
            cause = 'the drive refuses to switch on: check the enable input / STO and the DC link'
        else:
            cause = 'the drive did not follow: it may refuse in this mode or report why in an EMCY'
        self.ctx.add(Severity.WARNING, command.time, axis.node,
                     f'axis {axis.slot + 1}: controlword 0x{command.controlword:04X} ({command.name}) did not lead '
                     f'to {wanted}; the drive stayed in {axis.state.label}', cause, 'cia402-command', slot=axis.slot)

    def mode(self, t: float, node: int, slot: int, value: int) -> None:
        """0x6060 written: the drive should echo it in 0x6061 within the mode-switch time."""
        axis = self.axes.get((node, slot)) or self._axis(node, slot)
        self._check_mode(axis, t)
        value = _signed8(value)
        axis.mode_requested = None if value == axis.mode_display else (t, value)

    def mode_display(self, t: float, node: int, slot: int, value: int) -> None:
        axis = self.axes.get((node, slot)) or self._axis(node, slot)
        value = _signed8(value)
        if value != axis.mode_display:
            axis.mode_display = value
            axis.modes.append((t - self.ctx.t0, value))
        requested = axis.mode_requested
        if requested is not None:
            if requested[1] == value:
                axis.mode_requested = None
            else:
                self._check_mode(axis, t)

    def _check_mode(self, axis: AxisTrack, now: float) -> None:
        requested = axis.mode_requested
        if requested is None or now - requested[0] <= MODE_SWITCH_S or axis.mode_display is None:
            return
        axis.mode_requested = None
        shown = axis.mode_display
        self.ctx.add(Severity.WARNING, requested[0], axis.node,
                     f'axis {axis.slot + 1}: mode of operation {mode_name(requested[1])} ({requested[1]}) requested, '
                     f'the drive shows {mode_name(shown)} ({shown})',
                     'the drive does not support the mode, or refuses to switch in its present state',
                     'cia402-mode', slot=axis.slot)

    def _causes(self) -> None:
        """A Fault with no EMCY before it: the EMCY that came right after (the drive's statusword first)."""
        for index, node, t, count in self._uncaused:
            finding = self.ctx.findings[index]
            fault = self.emcy.fault_after(node, count, t, EMCY_AFTER_S)
            if fault is not None:
                after = f', {(fault.time - t) * 1000:.1f} ms after the statusword' if self.ctx.timing else ', after it'
                at = f' at t={fault.time:.3f} s' if self.ctx.timing else ''
                self.ctx.findings[index] = replace(finding, cause=f'{fault.text}{at}{after}',
                                                   short=f'{finding.short} (EMCY 0x{fault.event.code:04X})')
            else:
                self.ctx.findings[index] = replace(finding, cause='no EMCY seen: read the error code 0x603F')

    def finish(self, end: float) -> None:
        self._causes()
        if not self.ctx.timing:
            return
        for axis in self.axes.values():
            self._check_mode(axis, end)
            if axis.pending is not None and axis.pending.observed and end - axis.pending.time > STATE_SWITCH_S:
                self._failed(axis, axis.pending)


def _signed8(value: int) -> int:
    """0x6060 / 0x6061 are INTEGER8 (manufacturer modes are negative)."""
    value &= 0xFF
    return value - 0x100 if value & 0x80 else value
