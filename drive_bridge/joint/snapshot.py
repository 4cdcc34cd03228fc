"""Immutable state of one joint for the ROS layer: a drive-independent state every driver fills,
plus the CiA 402 fields (neutral values for drives without CiA 402)."""
from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Protocol

from drive_bridge.cia301.emcy import EmcyEvent


class DriveState(IntEnum):
    """What any drive is doing, in words a planner understands; values match
    ``AxisState.DRIVE_*`` of the interface package."""

    UNAVAILABLE = 0  # node not booted, lost, or no state received yet
    DISABLED = 1  # power stage off; enabling needs an explicit request
    READY = 2  # ready to enable (CiA 402: ready to switch on / switched on)
    ENABLED = 3  # power stage on, following commands
    STOPPING = 4  # quick stop or fault reaction in progress
    FAULT = 5  # a fault holds the drive; it needs a reset

    @property
    def label(self) -> str:
        return self.name.lower()


class DeviceState(Protocol):
    """A drive profile's device state as a snapshot carries it (CiA 402: ``cia402.statemachine.State``,
    which lives above this layer): a number for the interface package and a label for people."""

    @property
    def label(self) -> str: ...

    def __int__(self) -> int: ...


@dataclass(frozen=True)
class AxisSnapshot:
    """Immutable state of one joint."""

    joint: str
    node_id: int
    node_name: str
    slot: int
    available: bool
    nmt_state: str
    drive_state: DriveState
    state: DeviceState  # the CiA 402 State; State.UNKNOWN for drives without CiA 402
    statusword: int
    controlword: int
    mode: int  # modes of operation display (0x6061), or the family's own mode code
    mode_name: str
    requested_mode: int  # what the bridge requests
    position: float  # SI (rad or m); NaN when never received
    velocity: float
    effort: float
    stamp: float  # epoch seconds when the position was received
    fault: bool
    warning: bool
    target_reached: bool
    internal_limit: bool
    following_error: bool
    halted: bool
    command_stale: bool  # the command dead-man is holding the axis
    last_emcy: EmcyEvent | None
    message: str
    setpoint_refused: str = ''  # why the last cycle check refused a set-point and held the axis

    @property
    def state_label(self) -> str:
        """The CiA 402 state's name, or the drive-independent state for drives without one."""
        return self.state.label if int(self.state) else self.drive_state.label
