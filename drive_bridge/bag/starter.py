"""A starter bus config from a scan: every node found, with its family, identity, EDS and axes.

The identity (device type, vendor id, product code) goes into the node sections, so the
bridge refuses a different device at boot. ``dcf`` names the EDS that matched the node's
identity (``scan --eds``); where none did and no family knows the device by product, it is
TODO, which the loader refuses with what to give. Each axis' scaling and limits are TODO: the
bridge boots and reports state, and takes no command and no trajectory until they are set
(or ``scaling: none``), naming the keys (docs/configuration.md).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import yaml

from drive_bridge.bag.scan import FoundNode
from drive_bridge.config.keys import TODO
from drive_bridge.families import IdentityMatch, get_family

DEFAULT_MASTER_ID = 127


def master_node_id(found: Sequence[FoundNode]) -> int:
    """127 unless a node uses it, else the highest free id."""
    taken = {n.node_id for n in found}
    return next(i for i in range(DEFAULT_MASTER_ID, 0, -1) if i not in taken)


def node_name(node: FoundNode) -> str:
    return f'node_{node.node_id}'


def needs_dcf(node: FoundNode) -> bool:
    """No EDS of the node's family is known to fit it: the family ships none, or knows neither
    the node's product nor its vendor (a generic family, matched by the device type only)."""
    fits = bool(node.matches) and node.matches[0][0] >= IdentityMatch.VENDOR and node.family != 'generic_301'
    return not fits or get_family(node.family).eds_for(max(node.axes, 1)) is None


def axis_section(node: FoundNode, slot: int) -> dict[str, Any]:
    joint = f'{node_name(node)}_axis_{slot}' if node.axes > 1 else f'{node_name(node)}_joint'
    section: dict[str, Any] = {'joint': joint, 'slot': slot}
    if get_family(node.family).axes.uses_axis_scaling:
        section['scaling'] = {'counts_per_revolution': TODO}
    section['limits'] = {'min_position': TODO, 'max_position': TODO, 'max_velocity': TODO}
    return section


def node_section(node: FoundNode, dcf: str | None = None) -> dict[str, Any]:
    section: dict[str, Any] = {'node_id': node.node_id, 'family': node.family}
    if dcf is not None:
        section['dcf'] = dcf
    elif needs_dcf(node):
        section['dcf'] = TODO
    ident = node.identity
    for key, value in (('device_type', node.device_type), ('vendor_id', ident.vendor_id),
                       ('product_code', ident.product_code)):
        if value is not None:
            section[key] = f'0x{value:08X}'
    if node.axes:
        section['axes'] = [axis_section(node, slot) for slot in range(node.axes)]
    return section


def _comment(node: FoundNode, dcf: str | None, others: Sequence[str]) -> list[str]:
    lines = [f'  # node {node.node_id}: ' + ', '.join(x for x in (node.vendor, node.device_name) if x)
             if node.vendor or node.device_name else f'  # node {node.node_id}']
    ident = node.identity
    if ident.revision_number is not None or ident.serial_number is not None:
        revision = f'0x{ident.revision_number:08X}' if ident.revision_number is not None else '?'
        lines.append(f'  # revision {revision}, serial number {ident.serial_number} '
                     '(add revision_number / serial_number to pin this very device)')
    if len(node.matches) > 1 and node.matches[0][0] == node.matches[1][0]:
        lines.append('  # also fits family ' + ', '.join(f for m, f in node.matches[1:] if m == node.matches[0][0]))
    if dcf is not None:
        lines.append("  # dcf: the EDS whose identity is this device's"
                     + (f' (also: {", ".join(others)})' if others else ''))
    elif node.family == 'generic_301':
        lines.append('  # dcf: TODO: no drive family knows this device: its EDS (and rpdo/tpdo)')
    elif needs_dcf(node):
        ident = node.identity
        vendor = f'0x{ident.vendor_id:08X}' if ident.vendor_id is not None else '?'
        product = f'0x{ident.product_code:08X}' if ident.product_code is not None else '?'
        lines.append(f"  # dcf: TODO: the vendor's EDS for vendor {vendor}, product {product} "
                     '(scan --eds DIR looks for it)')
    if node.axes:
        lines.append('  # scaling and limits: TODO (the joint takes no command until they are set; '
                     '`scaling: none` for device units)')
    return lines


def starter_config(found: Sequence[FoundNode], interface: str, channel: str, bitrate: int | None,
                   dcf: Mapping[int, Sequence[str]] | None = None) -> str:
    """The YAML text of a bus config for the nodes found (docs/configuration.md); ``dcf``: per
    node id, the EDS files that match it, best first (the first is named)."""
    dcf = dcf or {}
    bus: dict[str, Any] = {'interface': interface, 'channel': channel}
    if bitrate:
        bus['bitrate'] = bitrate
    head = {'bus': bus, 'master': {'node_id': master_node_id(found), 'sync_period': 4000,
                                   'heartbeat_producer': 100},
            'defaults': {'heartbeat_producer': 100}}
    lines = [f'# Starter bus config written by `drive-bridge scan` for {len(found)} node(s) found on '
             f'{interface}:{channel}.',
             '# Fill in every TODO (docs/configuration.md): each axis takes no command until its scaling and',
             '# limits are set.',
             yaml.safe_dump(head, sort_keys=False).rstrip(), 'nodes:']
    for node in found:
        files = list(dcf.get(node.node_id, ()))
        named = files[0] if files else None
        lines += _comment(node, named, files[1:])
        body = yaml.safe_dump({node_name(node): node_section(node, named)}, sort_keys=False)
        lines += ['  ' + line for line in body.rstrip().splitlines()]
    if not found:
        lines[-1] = 'nodes: {}'
    return '\n'.join(lines) + '\n'
