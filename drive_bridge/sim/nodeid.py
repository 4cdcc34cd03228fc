"""A simulated slave taking a new node id, as a device does at its power-on when its address
was changed (a parameter or a switch read only then): the node leaves the bus under its old
id and joins it again under the new one, and the COB-IDs its EDS gives relative to the node id
($NODEID + base, still at their predefined value) follow it, as CiA 301's predefined connection
set does. Only while the node is powered off or initialising: nothing of the old id is answered
afterwards."""
from __future__ import annotations

from collections.abc import MutableMapping
from typing import Any

from drive_bridge.sim.slave import SimulatedSlave

# the function codes of the predefined connection set (CiA 301 Table 73)
PREDEFINED_BASES = frozenset({0x080, 0x180, 0x200, 0x280, 0x300, 0x380, 0x400, 0x480, 0x500, 0x580, 0x600, 0x700})
COB_ID_MASK = 0x7FF


def rebase(values: MutableMapping[int, Any], keys: list[int], old: int, new: int) -> None:
    """COB-IDs at ``keys`` that are a predefined base + ``old`` become base + ``new`` (flag bits
    such as 31 "invalid" kept)."""
    for k in keys:
        value = values.get(k)
        if isinstance(value, int) and (value & COB_ID_MASK) - old in PREDEFINED_BASES:
            values[k] = value - old + new


def change_node_id(slave: SimulatedSlave, new: int, *extra: MutableMapping[int, Any]) -> None:
    """Move ``slave`` (powered off or initialising) to node id ``new``; ``extra``: further value
    tables keyed like the store (a device's factory values) to rebase as well."""
    old = slave.node_id
    if new == old:
        return
    if not 1 <= new <= 127:
        raise ValueError(f'{slave.name}: node id {new} is not 1..127')
    relative = [k for k, var in slave.store.variables.items() if getattr(var, 'relative', False)]
    for table in (slave.store.values, slave.store.defaults, *extra):
        rebase(table, relative, old, new)
    network = slave.bus.network
    slave.detach()
    slave.node_id = new
    slave.sdo.local = slave.sdo.new_local_node()
    if network is not None:
        slave.attach(network)
