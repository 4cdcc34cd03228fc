"""What a test sees of one drive object of the simulated S120: a snapshot of its state,
statusword, modes, speeds, set-point, torque and active messages."""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from drive_bridge.cia402 import objects as obj
from drive_bridge.sim.s120.axis import S120Axis
from drive_bridge.sim.s120.emcy import Message


@dataclass(frozen=True)
class DriveObjectView:
    """What a test may see of one drive object (a snapshot)."""

    number: int
    slot: int | None  # axis slot; None for the Control Unit
    state: str  # CiA 402 state name ('' for the Control Unit)
    statusword: int
    mode: int  # 0x6061
    requested_mode: int  # 0x6060 as read back
    speed_rpm: float  # actual
    demand_rpm: float  # ramp-function generator output
    velocity: int  # 0x606C
    position: int  # 0x6063
    setpoint: float  # target of the running mode: 0x60FF (pv), 0x6042 (vl), 0x6071 (pt)
    torque: float  # actual, per mille of r0333
    faults: tuple[int, ...]
    alarms: tuple[int, ...]


class ViewedNode(Protocol):
    """The Control Unit as a view reads it."""

    @property
    def messages(self) -> Sequence[Message]: ...

    def drive_object(self, do: int) -> int: ...

    def axis_of(self, do: int) -> S120Axis | None: ...


def drive_object_view(node: ViewedNode, do: int) -> DriveObjectView:
    """A snapshot of drive object ``do`` (0: the first axis; 1: the Control Unit)."""
    number = node.drive_object(do)
    faults = tuple(m.number for m in node.messages if m.do == number and m.fault)
    alarms = tuple(m.number for m in node.messages if m.do == number and not m.fault)
    axis = node.axis_of(number)
    if axis is None:
        return DriveObjectView(number, None, '', 0, 0, 0, 0.0, 0.0, 0, 0, 0.0, 0.0, faults, alarms)
    mode = axis.mode
    if mode == 4:
        setpoint = float(axis.param(obj.TARGET_TORQUE, default=0))
    elif mode == 2:
        setpoint = float(axis.param(0x6042, default=0))
    else:
        setpoint = float(axis.param(obj.TARGET_VELOCITY, default=0))
    return DriveObjectView(
        number, axis.slot, axis.state.name, axis.compute_statusword(), mode, axis.requested_mode,
        axis.speed_rpm, axis.rpm(axis.dv), axis.to_bus(axis.v), axis.position if axis.encoder else 0,
        setpoint, axis.torque, faults, alarms)
