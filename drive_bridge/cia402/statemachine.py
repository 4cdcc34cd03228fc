"""The CiA 402 device state machine as pure functions: statusword to state, and the
controlword that moves a drive one transition closer to a wanted state.

Shared by the master (which decides controlwords) and the simulated drive (which
produces statuswords), so both speak exactly the same table (CiA 402-2 §8.1, and
docs/python-ecosystem.md §4.1).
"""
from __future__ import annotations

from enum import IntEnum


class State(IntEnum):
    """Device states; the values match ``AxisState.STATE_*`` of the interface package."""

    UNKNOWN = 0
    NOT_READY_TO_SWITCH_ON = 1
    SWITCH_ON_DISABLED = 2
    READY_TO_SWITCH_ON = 3
    SWITCHED_ON = 4
    OPERATION_ENABLED = 5
    QUICK_STOP_ACTIVE = 6
    FAULT_REACTION_ACTIVE = 7
    FAULT = 8

    @property
    def label(self) -> str:
        return self.name.replace('_', ' ').lower()


# statusword (mask, value) per state; mask first, never compare raw values
STATUSWORD_PATTERNS: tuple[tuple[State, int, int], ...] = (
    (State.NOT_READY_TO_SWITCH_ON, 0x4F, 0x00),
    (State.SWITCH_ON_DISABLED, 0x4F, 0x40),
    (State.READY_TO_SWITCH_ON, 0x6F, 0x21),
    (State.SWITCHED_ON, 0x6F, 0x23),
    (State.OPERATION_ENABLED, 0x6F, 0x27),
    (State.QUICK_STOP_ACTIVE, 0x6F, 0x07),
    (State.FAULT_REACTION_ACTIVE, 0x4F, 0x0F),
    (State.FAULT, 0x4F, 0x08),
)

# statusword bits
SW_READY_TO_SWITCH_ON = 1 << 0
SW_SWITCHED_ON = 1 << 1
SW_OPERATION_ENABLED = 1 << 2
SW_FAULT = 1 << 3
SW_VOLTAGE_ENABLED = 1 << 4
SW_QUICK_STOP = 1 << 5  # 1 = quick stop NOT active
SW_SWITCH_ON_DISABLED = 1 << 6
SW_WARNING = 1 << 7
SW_REMOTE = 1 << 9
SW_TARGET_REACHED = 1 << 10
SW_INTERNAL_LIMIT = 1 << 11
SW_OMS_12 = 1 << 12  # PP: set-point acknowledge; HM: homing attained; IP: IP mode active; CSx: follows target
SW_OMS_13 = 1 << 13  # PP/CSP: following error; HM: homing error

# controlword bits
CW_SWITCH_ON = 1 << 0
CW_ENABLE_VOLTAGE = 1 << 1
CW_QUICK_STOP = 1 << 2  # active low
CW_ENABLE_OPERATION = 1 << 3
CW_OMS_4 = 1 << 4  # PP: new set-point; HM: homing start; IP: enable IP mode
CW_OMS_5 = 1 << 5  # PP: change set immediately
CW_OMS_6 = 1 << 6  # PP: relative
CW_FAULT_RESET = 1 << 7
CW_HALT = 1 << 8

# device control commands (bits 0..3 and 7)
CMD_SHUTDOWN = 0x06
CMD_SWITCH_ON = 0x07
CMD_ENABLE_OPERATION = 0x0F
CMD_DISABLE_VOLTAGE = 0x00
CMD_QUICK_STOP = 0x02
CMD_DISABLE_OPERATION = 0x07
CMD_FAULT_RESET = 0x80
COMMAND_MASK = 0x8F


def state_from_statusword(statusword: int) -> State:
    """Decode the device state from a statusword (masked, as CiA 402 requires)."""
    for state, mask, value in STATUSWORD_PATTERNS:
        if statusword & mask == value:
            return state
    return State.UNKNOWN


def statusword_bits_for(state: State) -> int:
    """The state-defining statusword bits of ``state`` (for a drive producing a statusword)."""
    for candidate, _mask, value in STATUSWORD_PATTERNS:
        if candidate is state:
            return value
    raise ValueError(f'no statusword for state {state!r}')


def next_command(current: State, target: State) -> int | None:
    """Device control command (bits 0..3 of the controlword) for one step from
    ``current`` toward ``target``; None when there is nothing to send (already there,
    or the step needs a fault reset edge or is automatic).

    Supported targets: SWITCH_ON_DISABLED, READY_TO_SWITCH_ON, SWITCHED_ON,
    OPERATION_ENABLED and QUICK_STOP_ACTIVE.
    """
    if current is target:
        return None
    if current in (State.FAULT, State.FAULT_REACTION_ACTIVE, State.NOT_READY_TO_SWITCH_ON, State.UNKNOWN):
        return None  # fault: needs a reset edge (see fault_reset); others are automatic
    if target is State.SWITCH_ON_DISABLED:
        return CMD_DISABLE_VOLTAGE
    if target is State.QUICK_STOP_ACTIVE:
        return CMD_QUICK_STOP if current is State.OPERATION_ENABLED else CMD_DISABLE_VOLTAGE
    if current is State.QUICK_STOP_ACTIVE:
        return CMD_DISABLE_VOLTAGE  # transition 12; 16 (back to enabled) is drive-optional
    if current is State.SWITCH_ON_DISABLED:
        return CMD_SHUTDOWN  # transition 2
    if target is State.READY_TO_SWITCH_ON:
        return CMD_SHUTDOWN  # transitions 6, 8
    if target is State.SWITCHED_ON:
        return CMD_SWITCH_ON  # transitions 3, 5
    if target is State.OPERATION_ENABLED:
        return CMD_ENABLE_OPERATION if current is State.SWITCHED_ON else CMD_SWITCH_ON  # 4 / 3
    raise ValueError(f'unsupported target state {target!r}')


HOLD_COMMAND = {
    State.READY_TO_SWITCH_ON: CMD_SHUTDOWN,
    State.SWITCHED_ON: CMD_SWITCH_ON,
    State.OPERATION_ENABLED: CMD_ENABLE_OPERATION,
    State.QUICK_STOP_ACTIVE: CMD_QUICK_STOP,
}


def hold_command(current: State) -> int:
    """The device control command that keeps a drive in ``current`` (disable voltage where no
    command holds the state: it cannot raise any state)."""
    return HOLD_COMMAND.get(current, CMD_DISABLE_VOLTAGE)
