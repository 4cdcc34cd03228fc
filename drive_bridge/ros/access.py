"""The ``access`` rules applied to ROS clients' requests (docs/faults-and-security.md, "What ROS clients may do").

Only the services call this: the master's own boot and configuration writes never pass here.
A refusal is an :class:`AccessRefused` whose message starts with the service and the rule
('sdo_write refused by access.sdo_write: ...'), which the service returns as its message.
"""
from __future__ import annotations

from drive_bridge.access_rules import AccessConfig, NodeRule, ObjectRule
from drive_bridge.busproc.client import BusClient
from drive_bridge.families.interface import RESTORE_DEFAULT_PARAMETERS, STORE_PARAMETERS, DriveFamily
from drive_bridge.families.parameters import ParameterAccess
from drive_bridge.ros.errors import AccessRefused

HOW = 'allow it in the bus configuration'


def _refuse(service: str, rule: str, reason: str) -> AccessRefused:
    return AccessRefused(f'access.{rule}', f'{service} refused by access.{rule}: {reason}')


def _origin(rule: ObjectRule | NodeRule) -> str:
    return 'as configured' if rule.given else 'the default'


class AccessGuard:
    """Checks one request against the bus config's ``access`` rules; raises AccessRefused."""

    def __init__(self, access: AccessConfig, master: BusClient) -> None:
        self.access = access
        self.master = master
        self.configured = frozenset(node.node_id for node in master.nodes.values())

    def _writable(self, service: str) -> None:
        if self.access.read_only:
            raise _refuse(service, 'read_only', 'the bridge is read-only for ROS clients (reads stay open)')

    def _objects(self, service: str, key: str, node_id: int, index: int, subindex: int) -> None:
        rule: ObjectRule = getattr(self.access, key)
        if rule.allows(node_id, index):
            return
        ranges = ', '.join(str(r) for r in rule.ranges(node_id)) or 'none'
        closed = '; communication objects 0x1000-0x1FFF are closed to clients' if not rule.given else ''
        raise _refuse(service, key, f'node {node_id} 0x{index:04X}:{subindex:02X} is outside the objects clients '
                                    f'may reach on node {node_id} ({ranges}, {_origin(rule)}{closed}); '
                                    f'{HOW} (access.{key})')

    def _node(self, service: str, key: str, node_id: int, what: str) -> None:
        rule: NodeRule = getattr(self.access, key)
        if rule.allows(node_id, self.configured):
            return
        target = 'all nodes (node_id 0)' if node_id == 0 else f'node {node_id}'
        raise _refuse(service, key, f'{what} {target} is not allowed: the rule allows {rule} ({_origin(rule)}); '
                                    f'{HOW} (access.{key})')

    def _stores(self, node_id: int, index: int, subindex: int) -> bool:
        node = self.master.node_by_id(node_id)
        if node is not None:
            return node.family.stores_parameters(node.config, index, subindex)
        return index in (STORE_PARAMETERS, RESTORE_DEFAULT_PARAMETERS)  # outside the config: CiA 301 only

    # -- the services ---------------------------------------------------------------------------
    def sdo_read(self, node_id: int, index: int, subindex: int) -> None:
        self._objects('sdo_read', 'sdo_read', node_id, index, subindex)

    def _safety(self, service: str, node_id: int, what: str, reason: str | None, allowed: bool) -> None:
        if reason is None or allowed:
            return
        raise _refuse(service, 'safety_objects',
                      f'node {node_id} {what} is {reason}: it decides how the drive reacts when the bridge is lost '
                      'or how it communicates, so clients may not change it; name it in access.safety_objects to '
                      'allow it')

    def sdo_write(self, node_id: int, index: int, subindex: int) -> None:
        self._writable('sdo_write')
        self._objects('sdo_write', 'sdo_write', node_id, index, subindex)
        node = self.master.node_by_id(node_id)
        family = node.family if node is not None else DriveFamily()
        self._safety('sdo_write', node_id, f'0x{index:04X}:{subindex:02X}',
                     family.safety_object(node.config if node is not None else None, index, subindex),
                     self.access.safety_objects.allows_object(node_id, index))
        if self._stores(node_id, index, subindex):
            self._node('sdo_write', 'store_restore', node_id,
                       f'0x{index:04X}:{subindex:02X} stores or restores parameters: store/restore on')

    def nmt(self, node_id: int) -> None:
        self._writable('nmt')
        self._node('nmt', 'nmt', node_id, 'NMT to')

    # parameters exist for configured nodes only: another node id gets the master's error naming them
    def param_read(self, node_id: int) -> None:
        if node_id in self.configured:
            self._node('param_read', 'param_read', node_id, 'reading parameters of')

    def param_write(self, node_id: int, access: ParameterAccess | None, name: str) -> None:
        """Without the node's parameter access: the write rules; with it: whether ``name`` saves."""
        if access is None:
            self._writable('param_write')
            if node_id in self.configured:
                self._node('param_write', 'param_write', node_id, 'writing parameters of')
        else:
            self._safety('param_write', node_id, name.strip(), access.safety(name),
                         self.access.safety_objects.allows_name(node_id, name))
        if access is not None and access.stores(name):
            self._node('param_write', 'param_save', node_id,
                       f'{name.strip()} stores or restores parameters: saving on')

    def param_save(self, node_id: int) -> None:
        self._writable('param_save')
        if node_id in self.configured:
            self._node('param_save', 'param_save', node_id, 'saving parameters of')
