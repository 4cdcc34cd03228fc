"""What ROS clients may do: the bus config's ``access`` rules, through the services alone.

Three bridges on buses of their own, each with a generic CiA 402 drive (node 2, base_joint) and
a simulated Kollmorgen AKD (node 1, joint1): one with no ``access`` section (the defaults), one
with an explicit allow-list, one read-only. Every refusal names its rule in the message, and
the simulated drives show that nothing reached them; the bridge's own boot writes (0x1017, PDO
maps) go on whatever the rules say.
"""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from drive_bridge_interfaces.msg import SdoValue
from drive_bridge_interfaces.srv import AxisCommand, NmtCommand, ParamRead, ParamSave, ParamWrite, SdoRead, SdoWrite

from bridgetools import node_snapshot, start_bridge, stop_bridge
from bustools import demo_data
from rostools import RosHarness, ros_harness, wait_for

AKD_EXAMPLE = Path(__file__).resolve().parent.parent / 'config' / 'akd_pvt_example.yaml'
AKD, BASE = 1, 2
NVSAVE_OBJECT, ASCII_COMMAND = 0x35EB, 0x2026  # the AKD's DRV.NVSAVE and its ASCII channel (0x2026:1)
EXPLICIT = {
    'sdo_read': {'default': True, 'base_drive': ['0x6000-0x6FFF']},
    'sdo_write': {'default': [], BASE: ['0x1017', '0x1010-0x1011', '0x6000-0x6FFF'], 'akd': True},
    'store_restore': ['akd'],
    'nmt': [AKD],
    'param_read': False,
    'param_write': False,
    'param_save': [AKD],
    'safety_objects': {BASE: ['0x1017']},  # the heartbeat time is a safety object: named to be written
}


def config_data(access: dict[str, Any] | None) -> dict[str, Any]:
    data = demo_data()
    data['nodes'] = {'base_drive': data['nodes']['base_drive'],
                     'akd': yaml.safe_load(AKD_EXAMPLE.read_text())['nodes']['akd']}
    if access is not None:
        data['access'] = access
    return data


class Bridge:
    """A bus node on its own bus, and service calls to it."""

    def __init__(self, ros: RosHarness, name: str, access: dict[str, Any] | None) -> None:
        self.ros = ros
        self.name = name
        self.node = start_bridge(ros, config_data(access), node_name=name)
        self.client = ros.node(f'{name}_client')
        self.clients: dict[str, Any] = {}

    def call(self, srv_type: Any, service: str, **fields: Any) -> Any:
        if service not in self.clients:
            self.clients[service] = self.client.create_client(srv_type, f'/{self.name}/{service}')
        return self.ros.call(self.clients[service], srv_type.Request(**fields), timeout=15.0)

    def sdo_write(self, node_id: int, index: int, subindex: int, value: int, data_type: int = SdoValue.AUTO) -> Any:
        return self.call(SdoWrite, 'sdo_write', node_id=node_id, index=index, subindex=subindex,
                         value=SdoValue(data_type=data_type, uint_value=value))

    def sim(self, node_id: int) -> Any:
        return self.node.simulation.drive(node_id)

    def saved(self) -> dict[int, Any]:
        drive = self.sim(AKD)
        with drive.lock:
            return dict(drive.store.defaults)


@pytest.fixture(scope='module')
def bridges() -> Iterator[dict[str, Bridge]]:
    with ros_harness() as ros:
        made = {key: Bridge(ros, f'access_{key}', access) for key, access in
                (('default', None), ('explicit', EXPLICIT), ('read_only', {'read_only': True}))}
        try:
            for bridge in made.values():
                bridge.node.master.wait_until_operational(20.0)
            yield made
        finally:
            for bridge in made.values():
                stop_bridge(bridge.node)


def refused(response: Any, rule: str, *words: str) -> None:
    assert not response.success, response.message
    assert f'refused by {rule}:' in response.message, response.message
    for word in words:
        assert word in response.message, response.message


def test_defaults_close_communication_objects_and_saves_but_not_the_application(bridges: dict[str, Bridge]) -> None:
    bridge = bridges['default']
    assert bridge.call(SdoRead, 'sdo_read', node_id=BASE, index=0x1017, subindex=0).value.uint_value == 100
    assert bridge.sdo_write(BASE, 0x6065, 0, 4321).success
    assert bridge.sim(BASE).value(0x6065) == 4321

    heartbeat = bridge.sdo_write(BASE, 0x1017, 0, 0, SdoValue.UNSIGNED16)
    refused(heartbeat, 'access.sdo_write', 'node 2 0x1017:00', '0x2000-0xFFFF, the default',
            'communication objects 0x1000-0x1FFF are closed')
    assert bridge.sim(BASE).value(0x1017) == 100
    refused(bridge.sdo_write(BASE, 0x1010, 1, 0x65766173), 'access.sdo_write', '0x1010:01')

    before = bridge.saved()
    refused(bridge.sdo_write(AKD, NVSAVE_OBJECT, 0, 0, SdoValue.INTEGER32), 'access.store_restore',
            '0x35EB:00 stores or restores parameters', 'no node (the default)')
    refused(bridge.sdo_write(AKD, ASCII_COMMAND, 1, 0, SdoValue.UNSIGNED32), 'access.store_restore', '0x2026:01')
    refused(bridge.call(ParamWrite, 'param_write', node_id=AKD, parameter='drv.nvsave', value=''),
            'access.param_save', 'drv.nvsave stores or restores parameters')
    refused(bridge.call(ParamSave, 'param_save', joint='joint1'), 'access.param_save', 'saving parameters of node 1')
    written = bridge.call(ParamWrite, 'param_write', node_id=AKD, parameter='DRV.ACC', value='1000')
    assert written.success, written.message
    assert bridge.call(ParamRead, 'param_read', joint='joint1', parameter='DRV.ACC').success
    assert bridge.saved() == before  # nothing was stored


def test_default_nmt_reaches_configured_nodes_only_and_boot_writes_stay_open(bridges: dict[str, Bridge]) -> None:
    bridge = bridges['default']
    refused(bridge.call(NmtCommand, 'nmt', command=NmtCommand.Request.RESET_NODE, node_id=0), 'access.nmt',
            'all nodes (node_id 0)', 'the configured nodes (the default)')
    refused(bridge.call(NmtCommand, 'nmt', command=NmtCommand.Request.RESET_NODE, node_id=50), 'access.nmt',
            'node 50 is not allowed')
    attempts = node_snapshot(bridge.node, 'base_drive').boot_attempts
    reset = bridge.call(NmtCommand, 'nmt', command=NmtCommand.Request.RESET_NODE, node_id=BASE)
    assert reset.success, reset.message
    # the bridge configures the node again (0x1017, 0x1016, PDO maps): its own writes are not governed
    wait_for(lambda: (node := node_snapshot(bridge.node, 'base_drive')).boot_attempts > attempts and node.available,
             10, 'node 2 configured again')
    assert bridge.sim(BASE).value(0x1017) == 100


def test_explicit_allow_list_opens_and_closes_per_node(bridges: dict[str, Bridge]) -> None:
    bridge = bridges['explicit']
    assert bridge.sdo_write(BASE, 0x1017, 0, 100, SdoValue.UNSIGNED16).success  # listed for node 2
    refused(bridge.sdo_write(BASE, 0x1018, 1, 0, SdoValue.UNSIGNED32), 'access.sdo_write',
            '0x1017, 0x1010-0x1011, 0x6000-0x6FFF, as configured')
    refused(bridge.sdo_write(BASE, 0x1010, 1, 0x65766173), 'access.store_restore', 'nodes 1 (as configured)')
    refused(bridge.sdo_write(3, 0x6065, 0, 1, SdoValue.UNSIGNED32), 'access.sdo_write', 'node 3',
            '(none, as configured)')
    assert bridge.sdo_write(AKD, 0x1010, 1, 0x65766173).success  # store_restore allows the AKD

    refused(bridge.call(SdoRead, 'sdo_read', node_id=BASE, index=0x1018, subindex=1), 'access.sdo_read',
            '0x6000-0x6FFF')
    assert bridge.call(SdoRead, 'sdo_read', node_id=AKD, index=0x1018, subindex=1).success

    refused(bridge.call(NmtCommand, 'nmt', command=NmtCommand.Request.START, node_id=BASE), 'access.nmt', 'nodes 1')
    assert bridge.call(NmtCommand, 'nmt', command=NmtCommand.Request.START, node_id=AKD).success

    refused(bridge.call(ParamRead, 'param_read', joint='joint1', parameter='DRV.ACC'), 'access.param_read', 'no node')
    refused(bridge.call(ParamWrite, 'param_write', joint='joint1', parameter='DRV.ACC', value='1'),
            'access.param_write')
    saved = bridge.call(ParamSave, 'param_save', node_id=AKD)
    assert saved.success and 'DRV.NVSAVE' in saved.message, saved.message


def test_read_only_refuses_every_write_and_keeps_reads_and_motion(bridges: dict[str, Bridge]) -> None:
    bridge = bridges['read_only']
    before = bridge.sim(BASE).value(0x6065)
    refused(bridge.sdo_write(BASE, 0x6065, 0, before + 1), 'access.read_only', 'reads stay open')
    assert bridge.sim(BASE).value(0x6065) == before
    refused(bridge.call(NmtCommand, 'nmt', command=NmtCommand.Request.STOP, node_id=BASE), 'access.read_only')
    refused(bridge.call(ParamWrite, 'param_write', node_id=AKD, parameter='DRV.ACC', value='1'), 'access.read_only')
    refused(bridge.call(ParamSave, 'param_save', node_id=AKD), 'access.read_only')
    assert bridge.call(SdoRead, 'sdo_read', node_id=BASE, index=0x6065, subindex=0).value.uint_value == before
    assert bridge.call(ParamRead, 'param_read', node_id=AKD, parameter='DRV.ACC').success
    # the bridge booted the drives (its own writes) and axis services are not governed
    enabled = bridge.call(AxisCommand, 'enable', joints=['base_joint'])
    assert enabled.success, enabled.message
    assert node_snapshot(bridge.node, 'base_drive').available


def test_concurrent_requests_are_each_refused_and_the_node_keeps_serving(bridges: dict[str, Bridge]) -> None:
    bridge = bridges['default']
    client = bridge.client.create_client(SdoWrite, f'/{bridge.name}/sdo_write')
    assert client.wait_for_service(timeout_sec=10)
    # within the service's request queue (depth 10): a deeper burst is dropped by the middleware
    futures = [client.call_async(SdoWrite.Request(node_id=BASE, index=0x1000 + i, subindex=0,
                                                  value=SdoValue(data_type=SdoValue.UNSIGNED8, uint_value=1)))
               for i in range(8)]
    wait_for(lambda: all(f.done() for f in futures), 20, 'all 8 answers')
    answers = [f.result() for f in futures]
    assert all(not a.success and 'refused by access.sdo_write' in a.message for a in answers)
    assert bridge.sdo_write(BASE, 0x6065, 0, 777).success
