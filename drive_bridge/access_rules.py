"""What ROS clients may reach through the services that write or address nodes: the typed form of
the bus configuration's ``access`` section (object ranges per service and node, the nodes a
service may address, the safety objects a client may write anyway). Its own module beside
:mod:`drive_bridge.model`, which holds it in ``BusConfig.access``: a rule is checked by the ROS
layer and the loader, never by the core.
"""
from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass, field


@dataclass(frozen=True)
class ObjectRange:
    """Object indices ``first``..``last`` (inclusive)."""

    first: int
    last: int

    def __contains__(self, index: object) -> bool:
        return isinstance(index, int) and self.first <= index <= self.last

    def __str__(self) -> str:
        return f'0x{self.first:04X}' if self.first == self.last else f'0x{self.first:04X}-0x{self.last:04X}'


EVERY_OBJECT = (ObjectRange(0x0000, 0xFFFF),)
# everything above the communication profile area (0x1000-0x1FFF, CiA 301)
APPLICATION_OBJECTS = (ObjectRange(0x2000, 0xFFFF),)


@dataclass(frozen=True)
class ObjectRule:
    """Which object indices ROS clients may reach through one service: per node id, else
    ``default``. ``given``: set in the bus configuration (False: the bridge's default)."""

    default: tuple[ObjectRange, ...]
    nodes: Mapping[int, tuple[ObjectRange, ...]] = field(default_factory=dict)
    given: bool = False

    def ranges(self, node_id: int) -> tuple[ObjectRange, ...]:
        return self.nodes.get(node_id, self.default)

    def allows(self, node_id: int, index: int) -> bool:
        return any(index in r for r in self.ranges(node_id))


@dataclass(frozen=True)
class NodeRule:
    """Which nodes ROS clients may address through one service: any node id (NMT: also 0,
    all nodes, and nodes outside the configuration), the configured nodes, those listed, or none."""

    any_node: bool = False
    configured: bool = False
    node_ids: frozenset[int] = frozenset()
    given: bool = False

    def allows(self, node_id: int, configured_ids: Collection[int]) -> bool:
        if self.any_node:
            return True
        return node_id != 0 and (node_id in self.node_ids or (self.configured and node_id in configured_ids))

    def __str__(self) -> str:
        if self.any_node:
            return 'any node'
        if self.configured:
            return 'the configured nodes'
        return ('nodes ' + ', '.join(str(n) for n in sorted(self.node_ids))) if self.node_ids else 'no node'


@dataclass(frozen=True)
class SafetyAllowance:
    """Safety objects (indices) and vendor parameters (names, upper case, without an index)
    that ROS clients may write anyway: per node id, else ``default`` (the bus config's
    ``access.safety_objects``; by default none)."""

    default: tuple[tuple[ObjectRange, ...], frozenset[str]] = ((), frozenset())
    nodes: Mapping[int, tuple[tuple[ObjectRange, ...], frozenset[str]]] = field(default_factory=dict)
    every: bool = False  # ``true``: every safety object of every node

    def allows_object(self, node_id: int, index: int) -> bool:
        ranges = self.nodes.get(node_id, self.default)[0]
        return self.every or any(index in r for r in ranges)

    def allows_name(self, node_id: int, name: str) -> bool:
        names = self.nodes.get(node_id, self.default)[1]
        return self.every or safety_name(name) in names


def safety_name(name: str) -> str:
    """A vendor parameter's name as the allowance compares it: 'p8641[0]' -> 'P8641'."""
    text = name.strip().upper()
    for mark in ('[', '.'):
        head, sep, tail = text.partition(mark)
        if sep and (mark == '[' or tail.isdigit()):
            text = head
    return text.replace(' ', '')


@dataclass(frozen=True)
class AccessConfig:
    """What ROS clients may do through the services that write (the bus config's ``access``).

    It governs client requests only: the bridge's own boot and configuration writes never pass
    through it. Store/restore (0x1010/0x1011 and what the drive family names a save) is refused
    unless ``store_restore`` allows the node, even where ``sdo_write``'s ranges include it.
    """

    read_only: bool = False
    sdo_read: ObjectRule = ObjectRule(EVERY_OBJECT)
    sdo_write: ObjectRule = ObjectRule(APPLICATION_OBJECTS)
    store_restore: NodeRule = NodeRule()
    nmt: NodeRule = NodeRule(configured=True)
    param_read: NodeRule = NodeRule(configured=True)
    param_write: NodeRule = NodeRule(configured=True)
    param_save: NodeRule = NodeRule()
    safety_objects: SafetyAllowance = SafetyAllowance()
