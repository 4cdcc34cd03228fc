"""Tests of the ROS node with simulated drives the test can inspect.

The node starts its bus process (the Master, the cycle) as a child; simulated drives inside
that process cannot be seen from the test. :func:`start_bridge` therefore runs the
configuration's simulated drives in the test's own process, on a ``local`` bus (Unix datagram
sockets) that the bus process opens too: the bridge reaches them only through CAN frames, and
``node.simulation`` is the test's :class:`~drive_bridge.sim.SimulatedBus`.
"""
from __future__ import annotations

import copy
import os
import threading
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

import can
import yaml
from rclpy.parameter import Parameter

from akdtools import Sniffer
from bustools import config_from, unique_channel
from drive_bridge.master.bus import open_bus
from drive_bridge.master.node import NodeSnapshot
from drive_bridge.ros.lifecycle import BusLifecycleNode
from drive_bridge.ros.node import BusNode
from drive_bridge.sim import SimulatedBus
from rostools import RosHarness


def local_data(data: dict[str, Any], channel: str | None = None) -> dict[str, Any]:
    """``data`` on a ``local`` bus of its own (its simulation left to the caller)."""
    data = copy.deepcopy(data)
    bus = dict(data.get('bus') or {})
    bus.update(interface='local', channel=channel or unique_channel(f'ros{os.getpid()}'))
    data['bus'] = bus
    return data


def simulated(data: dict[str, Any]) -> SimulatedBus:
    """The simulated drives of ``data`` (a local-bus config) on its channel, started. The
    simulation section is read as on a virtual bus (the loader allows it there only)."""
    virtual = copy.deepcopy(data)
    virtual['bus'] = {**virtual['bus'], 'interface': 'virtual'}
    virtual['simulation'] = {**(virtual.get('simulation') or {}), 'enabled': True}
    config = config_from(virtual)
    bus = data['bus']
    return SimulatedBus(config, bus=open_bus('local', bus['channel'], bus.get('bitrate'))).start()


def bridge_config(data: dict[str, Any]) -> str:
    """The node's bus configuration: ``data`` without the simulation (the test runs it)."""
    bridge = copy.deepcopy(data)
    bridge['simulation'] = {'enabled': False}
    return yaml.safe_dump(bridge, sort_keys=False)


@contextmanager
def bridge_with_sim(ros: RosHarness, data: dict[str, Any], params: Iterable[Parameter] = (),
                    lifecycle: bool = False, **node_options: Any) -> Iterator[BusNode]:
    """A bus node on a local bus with the config's simulated drives in this process
    (``node.simulation``); both stopped afterwards."""
    data = local_data(data)
    sim = simulated(data)
    node_class = BusLifecycleNode if lifecycle else BusNode
    try:
        node = node_class(context=ros.context, parameter_overrides=[
            Parameter('config_yaml', value=bridge_config(data)), *params], **node_options)
    except Exception:
        sim.stop()
        raise
    node.simulation = sim  # type: ignore[attr-defined]
    ros.add(node)
    try:
        yield node
    finally:
        node.close()
        sim.stop()


def node_snapshot(node: BusNode, name: str) -> NodeSnapshot:
    """A node's state as the bus process last reported it (the test query for what the master
    knows of a node: boot attempts, NMT state, EMCY history)."""
    return next(n for n in node.master.snapshot().nodes if n.name == name)


class LocalSniffer(Sniffer):
    """akdtools.Sniffer on a ``local`` channel (every frame the bridge and the drives send)."""

    def __init__(self, channel: str) -> None:  # noqa: D107 (the parent's, on another interface)
        self._bus = open_bus('local', channel)
        self._frames = []
        self._cond = threading.Condition()
        self._notifier = can.Notifier(self._bus, [self._on_message], timeout=0.05)
