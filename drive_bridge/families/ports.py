"""What a family's hooks may use of a node at run time (implemented by the master's
``NodeRuntime``): typed SDO, NMT, its configuration. Families sit below the master, so they
see it only through these protocols."""
from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from drive_bridge.joint.nodeio import SdoValue
from drive_bridge.model import NodeConfig


class NodePort(Protocol):
    """A node as boot steps and parameter access see it. SDO failures raise the master's
    ``SdoError`` (a ``DriveBridgeError`` naming node, object and abort code)."""

    @property
    def node_id(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def config(self) -> NodeConfig: ...

    def sdo_read(self, index: int, subindex: int = 0) -> SdoValue: ...
    def sdo_write(self, index: int, subindex: int, value: int | float) -> None: ...
    def sdo_read_raw(self, index: int, subindex: int = 0) -> bytes: ...
    def sdo_write_raw(self, index: int, subindex: int, data: bytes) -> None: ...
    def send_nmt(self, command: int) -> None: ...
    def has_object(self, index: int, subindex: int = 0) -> bool: ...


BootStep = tuple[str, Callable[[NodePort], None]]
"""A named boot step; it raises (SdoError, DriveBridgeError) to fail the boot with its name."""
