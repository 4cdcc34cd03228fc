"""Drive parameters by their vendor names: the seam between a drive family and the bridge.

A family that can read and write its drives' own parameters (AKD ``DRV.ACC`` over the ASCII
channel, S120 ``p2000`` via 0x2000+ and a drive-object selector, OPEN drive ``P162`` / ``C52``
with format words) returns a :class:`ParameterAccess` from ``DriveFamily.parameters(port)``;
the master gives it a :class:`ParameterPort` (raw SDO to one node) and the ROS layer's
``~/param_read`` / ``~/param_write`` / ``~/param_save`` services call it.

This module sits below the master (no import of ``drive_bridge.master`` or ROS): a family
sees its node only through the port. Every failure is a :class:`ParameterError` whose text
names the node, the parameter and what was wrong.
"""
from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Protocol

from drive_bridge.families.errors import ParameterError


class ParameterPort(Protocol):
    """What a family's parameter access needs from its node: raw SDO, the node's id and name.

    ``sdo_read_raw`` / ``sdo_write_raw`` raise whatever the port raises when the SDO fails
    (the master's port: ``SdoError`` with the abort text); the family turns that into a
    :class:`ParameterError` naming the parameter.
    """

    @property
    def node_id(self) -> int: ...

    @property
    def name(self) -> str: ...

    def sdo_read_raw(self, index: int, subindex: int) -> bytes: ...

    def sdo_write_raw(self, index: int, subindex: int, data: bytes) -> None: ...


def node_label(port: ParameterPort) -> str:
    """'node 3 (axis_a)'."""
    return f'node {port.node_id} ({port.name})' if port.name else f'node {port.node_id}'


def parameter_error(port: ParameterPort, parameter: str, reason: str, drive_text: str = '') -> ParameterError:
    """'node 3 (axis_a): DRV.ACC: <reason>', with the fields set."""
    where = f'{node_label(port)}: {parameter}: ' if parameter else f'{node_label(port)}: '
    return ParameterError(where + reason, node_id=port.node_id, parameter=parameter, drive_text=drive_text)


@dataclass(frozen=True)
class ParameterValue:
    """One parameter as the drive reported it, with what the family knows of it.

    ``value`` is the number when the value is one (else None); ``minimum`` / ``maximum``
    the range a write must keep to (None: unknown); ``access`` "rw", "ro", "wo", "cmd"
    (a command taking no value) or a family's class text; ``save_needed`` that a written
    value takes effect only after a save (and restart), or is lost at power-off without
    one; ``note`` anything else worth telling (e.g. "needs DRV.NVSAVE and a 24 V restart").
    """

    name: str
    value_text: str
    value: float | None
    unit: str
    minimum: float | None
    maximum: float | None
    access: str
    save_needed: bool
    note: str = ''

    @property
    def has_range(self) -> bool:
        return self.minimum is not None and self.maximum is not None

    def describe(self) -> str:
        """'DRV.ACC = 1000.000 [rpm/s]'."""
        unit = f' [{self.unit}]' if self.unit and self.unit not in self.value_text else ''
        return f'{self.name} = {self.value_text}{unit}'


class ParameterAccess(ABC):
    """A family's access to the vendor parameters of one node (one instance per node;
    calls may come from several threads and are serialized by the implementation)."""

    @abstractmethod
    def read(self, name: str, drive_object: int = 0) -> ParameterValue:
        """The present value of ``name``; ParameterError on failure."""

    @abstractmethod
    def write(self, name: str, value_text: str, drive_object: int = 0) -> ParameterValue:
        """Check ``value_text`` against what the family knows of ``name``, write it, and
        return the value as the drive reports it afterwards; ParameterError on failure."""

    @abstractmethod
    def save(self, drive_object: int = 0) -> str:
        """Store the parameters in the drive's non-volatile memory; returns what was done."""

    def stores(self, name: str) -> bool:
        """Writing ``name`` stores or restores the drive's parameters (a save or load command):
        the bridge treats such a write as a save (``~/param_save``'s rule). By default none does."""
        return False

    def safety(self, name: str) -> str | None:
        """What writing ``name`` changes when it decides how the drive reacts to the loss of its
        master or changes its communication (node id, bit rate, guarding, heartbeat, SYNC), else
        None: the bridge refuses such writes from clients unless ``access.safety_objects`` names
        them. By default none does."""
        return None

    def for_slot(self, slot: int) -> ParameterAccess:
        """This access as the joint in axis ``slot`` of the node sees it: ``drive_object`` 0 then
        means that joint's own drive object (a node with several). By default the same access."""
        return self


def format_number(value: float) -> str:
    """A number as a drive's ASCII parser takes it: no exponent, at most 3 decimals."""
    if not math.isfinite(value):
        raise ValueError(f'{value} is not a finite number')
    if value == int(value):
        return str(int(value))
    return f'{value:.3f}'.rstrip('0').rstrip('.')


def format_limit(value: float) -> str:
    """A range limit for a message: 2147483647, 4294967.295, -0.5."""
    return format_number(value) if abs(value) < 1e15 else f'{value:g}'
