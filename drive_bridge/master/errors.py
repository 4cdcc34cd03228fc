"""Errors of the master: an SDO that failed and a boot step that failed.

They live apart from the code that raises them so that the modules which only catch or keep
them (the node's runtime keeps its last boot refusal) need not import the boot or SDO code.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from drive_bridge.errors import DriveBridgeError


@dataclass(frozen=True)
class ObjectAddress:
    """The object an SDO addressed: node, index, sub-index (CiA 301)."""

    node_id: int
    index: int
    subindex: int

    def __str__(self) -> str:
        return f'node {self.node_id} object 0x{self.index:04X}:{self.subindex:02X}'


class SdoError(DriveBridgeError):
    """An SDO that failed: abort by the node (``abort_code`` set), timeout, or bad value."""

    def __init__(self, where: ObjectAddress, message: str, abort_code: int = 0) -> None:
        super().__init__(f'{where}: {message}')
        self.where = where
        self.abort_code = abort_code
        self.reason = message


class NamedNode(Protocol):
    """What a boot error names of the node that failed (a node's runtime is one)."""

    @property
    def node_id(self) -> int: ...

    @property
    def name(self) -> str: ...


class BootError(DriveBridgeError):
    """A boot step failed."""

    def __init__(self, node: NamedNode, step: str, message: str, abort_code: int = 0) -> None:
        super().__init__(f'node {node.node_id} ({node.name}) boot step "{step}": {message}')
        self.step = step
        self.abort_code = abort_code
