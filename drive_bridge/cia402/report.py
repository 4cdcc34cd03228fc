"""What a CiA 402 axis reports of its drive beyond the objects it reads: the drive-independent
state of each CiA 402 state, and its fault: the EMCY that explains it and the drive's error code
0x603F, for refusals and the way out."""
from __future__ import annotations

from drive_bridge.cia301.emcy import EmcyEvent, Severity
from drive_bridge.cia402.statemachine import State
from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint import DriveState, NodeIo
from drive_bridge.joint.faults import fault_refusal

DRIVE_STATE = {
    State.UNKNOWN: DriveState.UNAVAILABLE,
    State.NOT_READY_TO_SWITCH_ON: DriveState.DISABLED,
    State.SWITCH_ON_DISABLED: DriveState.DISABLED,
    State.READY_TO_SWITCH_ON: DriveState.READY,
    State.SWITCHED_ON: DriveState.READY,
    State.OPERATION_ENABLED: DriveState.ENABLED,
    State.QUICK_STOP_ACTIVE: DriveState.STOPPING,
    State.FAULT_REACTION_ACTIVE: DriveState.STOPPING,
    State.FAULT: DriveState.FAULT,
}


def _sdo_number(value: int | float | str | bytes) -> int | None:
    return None if isinstance(value, (str, bytes)) else int(value)


class FaultReport:
    """The fault of one axis (slot ``slot`` of its node), said from its EMCY history since its
    last fault reset and its error code object."""

    def __init__(self, node: NodeIo, error_code: tuple[int, int], slot: int) -> None:
        self.node = node
        self.error_code = error_code
        self.slot = slot
        self.reset_count = 0  # EMCYs before the last fault reset: history

    def mark_reset(self) -> None:
        """A fault reset succeeded: the EMCYs until now no longer explain the axis' state."""
        self.reset_count = len(self.node.emcy_history())

    def last_emcy(self) -> EmcyEvent | None:
        """The newest EMCY of this axis since its last fault reset that explains it: the newest
        error, else the newest warning (a later warning does not hide the fault's cause)."""
        history = [e for e in self.node.emcy_history()[self.reset_count:]
                   if not e.is_reset and e.slot in (None, self.slot)]
        errors = [e for e in history if e.severity is Severity.ERROR]
        return errors[-1] if errors else (history[-1] if history else None)

    def emcy_text(self) -> str:
        """'; last EMCY 0x.... text', or '' (appended to a failed intent's error)."""
        emcy = self.last_emcy()
        return f'; last EMCY 0x{emcy.code:04X} {emcy.text}' if emcy else ''

    def description(self) -> str:
        """The last EMCY and the drive's error code 0x603F (mapped, else read by SDO), the way out."""
        details = []
        mapped = self.node.has_object(*self.error_code)
        code = self.node.read(*self.error_code) if mapped else None
        if code is None and mapped:
            try:
                code = _sdo_number(self.node.sdo_read(*self.error_code))
            except DriveBridgeError:
                code = None
        if code:
            details.append(f'0x603F error code 0x{int(code):04X}')
        return fault_refusal(self.last_emcy(), details)
