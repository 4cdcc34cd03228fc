"""Tests of the ROS node with simulated drives the test can inspect.

The node starts its bus process (the Master, the cycle) as a child; simulated drives inside
that process cannot be seen from the test. :func:`start_bridge` (:func:`bridge_with_sim`)
therefore runs the configuration's simulated drives in the test's own process, on a ``local``
bus (Unix datagram sockets) that the bus process opens too: the bridge reaches them only
through CAN frames, and ``node.simulation`` is the test's :class:`~drive_bridge.sim.SimulatedBus`.
A test that injects or records raw frames joins that bus (:func:`sniffing`, :class:`LocalSniffer`).
"""
from __future__ import annotations

import copy
import os
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

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
from timingtools import fresh_snapshot  # noqa: F401 (the tests import it from here too), wait_for


def local_data(data: dict[str, Any], channel: str | None = None) -> dict[str, Any]:
    """``data`` on a ``local`` bus of its own (its simulation left to the caller); data already
    on a local channel keeps it (a test may have joined it before the node starts)."""
    data = copy.deepcopy(data)
    bus = dict(data.get('bus') or {})
    if channel is None and bus.get('interface') == 'local':
        channel = bus.get('channel')
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


def start_bridge(ros: RosHarness, data: dict[str, Any], params: Iterable[Parameter] = (),
                 lifecycle: bool = False, **node_options: Any) -> BusNode:
    """A bus node on a local bus with the config's simulated drives in this process
    (``node.simulation``), spun by ``ros``; :func:`stop_bridge` ends both."""
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
    return node


def stop_bridge(node: BusNode) -> None:
    """Close the node (its bus process stops the axes and ends), then stop its simulated drives."""
    try:
        node.close()
    finally:
        node.simulation.stop()  # type: ignore[attr-defined]


@contextmanager
def bridge_with_sim(ros: RosHarness, data: dict[str, Any], params: Iterable[Parameter] = (),
                    lifecycle: bool = False, **node_options: Any) -> Iterator[BusNode]:
    """:func:`start_bridge` for the ``with`` block; both stopped afterwards."""
    node = start_bridge(ros, data, params, lifecycle, **node_options)
    try:
        yield node
    finally:
        stop_bridge(node)


def channel_of(node: BusNode) -> str:
    """The node's local channel (the bus process, the simulated drives and any sniffer share it)."""
    return str(node.master.config.bus.channel)


@contextmanager
def sniffing(node: BusNode) -> Iterator[Sniffer]:
    """A participant of the node's local bus that records every frame (the bridge's and the
    drives') and sends what the test injects. It reads all the time: a local peer that does not
    read holds every sender back (``transport.local``)."""
    sniffer = Sniffer(channel_of(node), interface='local')
    try:
        yield sniffer
    finally:
        sniffer.close()




def node_snapshot(node: BusNode, name: str, fresh: bool = False) -> NodeSnapshot:
    """A node's state as the bus process last reported it (the test query for what the master
    knows of a node: boot attempts, NMT state, EMCY history); ``fresh``: as it is now
    (:func:`fresh_snapshot`)."""
    snapshot = fresh_snapshot(node) if fresh else node.master.snapshot()
    return next(n for n in snapshot.nodes if n.name == name)


class LocalSniffer(Sniffer):
    """akdtools.Sniffer on a ``local`` channel (every frame the bridge and the drives send)."""

    def __init__(self, channel: str) -> None:
        super().__init__(channel, interface='local')
