"""A starter bus config from a scan: every node found, with its family, identity and axes.

The identity (device type, vendor id, product code) goes into the node sections, so the
bridge refuses a different device at boot; scaling and limits are left for the integrator
(the config loader warns that device units pass through unscaled).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import yaml

from drive_bridge.bag.scan import FoundNode
from drive_bridge.families import get_family

DEFAULT_MASTER_ID = 127


def master_node_id(found: Sequence[FoundNode]) -> int:
    """127 unless a node uses it, else the highest free id."""
    taken = {n.node_id for n in found}
    return next(i for i in range(DEFAULT_MASTER_ID, 0, -1) if i not in taken)


def node_name(node: FoundNode) -> str:
    return f'node_{node.node_id}'


def node_section(node: FoundNode) -> dict[str, Any]:
    section: dict[str, Any] = {'node_id': node.node_id, 'family': node.family}
    ident = node.identity
    for key, value in (('device_type', node.device_type), ('vendor_id', ident.vendor_id),
                       ('product_code', ident.product_code)):
        if value is not None:
            section[key] = f'0x{value:08X}'
    if node.axes:
        section['axes'] = [{'joint': f'{node_name(node)}_axis_{slot}' if node.axes > 1 else f'{node_name(node)}_joint',
                            'slot': slot} for slot in range(node.axes)]
    return section


def _comment(node: FoundNode) -> list[str]:
    lines = [f'  # node {node.node_id}: ' + ', '.join(x for x in (node.vendor, node.device_name) if x)
             if node.vendor or node.device_name else f'  # node {node.node_id}']
    ident = node.identity
    if ident.revision_number is not None or ident.serial_number is not None:
        revision = f'0x{ident.revision_number:08X}' if ident.revision_number is not None else '?'
        lines.append(f'  # revision {revision}, serial number {ident.serial_number} '
                     '(add revision_number / serial_number to pin this very device)')
    if len(node.matches) > 1 and node.matches[0][0] == node.matches[1][0]:
        lines.append('  # also fits family ' + ', '.join(f for m, f in node.matches[1:] if m == node.matches[0][0]))
    if get_family(node.family).eds_for(max(node.axes, 1)) is None and node.family != 'generic_301':
        lines.append(f"  # family {node.family} ships no EDS: add dcf: <the vendor's EDS>")
    elif node.family == 'generic_301':
        lines.append("  # no drive family knows this device: add dcf: <its EDS> (and rpdo/tpdo)")
    return lines


def starter_config(found: Sequence[FoundNode], interface: str, channel: str, bitrate: int | None) -> str:
    """The YAML text of a bus config for the nodes found (docs/configuration.md)."""
    bus: dict[str, Any] = {'interface': interface, 'channel': channel}
    if bitrate:
        bus['bitrate'] = bitrate
    head = {'bus': bus, 'master': {'node_id': master_node_id(found), 'sync_period': 4000,
                                   'heartbeat_producer': 100},
            'defaults': {'heartbeat_producer': 100}}
    lines = [f'# Starter bus config written by `drive-bridge scan` for {len(found)} node(s) found on '
             f'{interface}:{channel}.',
             '# Give each axis its scaling and limits (docs/configuration.md) before moving anything.',
             yaml.safe_dump(head, sort_keys=False).rstrip(), 'nodes:']
    for node in found:
        lines += _comment(node)
        body = yaml.safe_dump({node_name(node): node_section(node)}, sort_keys=False)
        lines += ['  ' + line for line in body.rstrip().splitlines()]
    if not found:
        lines[-1] = 'nodes: {}'
    return '\n'.join(lines) + '\n'
