"""Drive parameters through ROS: ~/param_read, ~/param_write, ~/param_save on the bus node.

A demo-like bridge (the demo's generic CiA 402 base drive, node 2, plus a simulated Kollmorgen
AKD as node 1, joint1, both simulated in the test's process: bridgetools) runs on a private
rclpy context; the test talks to it only
through the services and inspects the simulated AKD to see what reached it.
"""
from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from drive_bridge_interfaces.srv import ParamRead, ParamSave, ParamWrite

from bridgetools import bridge_with_sim
from bustools import demo_data
from drive_bridge.ros.node import BusNode
from rostools import RosHarness, ros_harness

NS = '/drive_bridge'
AKD_EXAMPLE = Path(__file__).resolve().parent.parent / 'config' / 'akd_pvt_example.yaml'


def config_data() -> dict[str, Any]:
    data = demo_data()
    data['nodes'] = {'base_drive': data['nodes']['base_drive'],
                     'akd': yaml.safe_load(AKD_EXAMPLE.read_text())['nodes']['akd']}
    data['access'] = {'param_save': 'configured'}  # ROS clients may not save by default
    return data


@pytest.fixture(scope='module')
def setup() -> Iterator[tuple[RosHarness, BusNode]]:
    with ros_harness() as ros, bridge_with_sim(ros, config_data()) as node:  # the drives in the test
        node.master.wait_until_operational(15.0)
        yield ros, node


def call(ros: RosHarness, srv_type: Any, name: str, **fields: Any) -> Any:
    client = ros.node(f'param_client_{time.monotonic_ns() % 1000000}').create_client(srv_type, f'{NS}/{name}')
    return ros.call(client, srv_type.Request(**fields), timeout=15.0)


def test_param_read_by_joint_and_by_node(setup: tuple[RosHarness, BusNode]) -> None:
    ros, bridge = setup
    drive = bridge.simulation.drive(1)
    read = call(ros, ParamRead, 'param_read', joint='joint1', parameter='DRV.ACC')
    assert read.success, read.message
    assert read.is_number and read.value == drive.value(0x3501) and read.unit == 'counts/s^2'
    assert read.has_range and (read.minimum, read.maximum) == (-2 ** 31, 2 ** 31 - 1)
    assert read.access == 'rw' and read.save_needed
    assert read.message.startswith('joint joint1: DRV.ACC = ')
    by_node = call(ros, ParamRead, 'param_read', node_id=1, parameter='drv.faults')
    assert by_node.success and by_node.value_text == 'No faults active' and not by_node.is_number
    assert not by_node.has_range and by_node.access == 'ro'


def test_param_write_then_save(setup: tuple[RosHarness, BusNode]) -> None:
    ros, bridge = setup
    drive = bridge.simulation.drive(1)
    written = call(ros, ParamWrite, 'param_write', joint='joint1', parameter='MOTOR.ICONT', value='2.5')
    assert written.success, written.message
    assert written.value == 2.5 and written.value_text == '2.500' and written.unit == 'A' and written.save_needed
    assert 'param_save' in written.message  # says the value is lost without a save
    assert drive.value(0x358E) == 2500
    saved = call(ros, ParamSave, 'param_save', node_id=1)
    assert saved.success and 'DRV.NVSAVE' in saved.message, saved.message
    with drive.lock:
        assert drive.store.defaults[0x358E << 8] == 2500  # the power-on value now


@pytest.mark.parametrize('srv, name, fields, reason', [
    (ParamRead, 'param_read', {'joint': 'wrist_joint', 'parameter': 'DRV.ACC'},
     "unknown joint 'wrist_joint'; this bus has base_joint, joint1"),
    (ParamRead, 'param_read', {'joint': 'joint1', 'parameter': 'DRV.ACCC'},
     'joint joint1: node 1 (akd): DRV.ACCC: unknown AKD parameter; did you mean DRV.ACC'),
    (ParamWrite, 'param_write', {'node_id': 1, 'parameter': 'DRV.ACC', 'value': '5e9'},
     'node 1 (akd): DRV.ACC: 5e9 is above the maximum 2147483647'),
    (ParamWrite, 'param_write', {'node_id': 1, 'parameter': 'VL.FB', 'value': '1'},
     'node 1 (akd): VL.FB: is read-only'),
    (ParamRead, 'param_read', {'joint': 'base_joint', 'parameter': 'DRV.ACC'},
     "joint base_joint: node 2 (base_drive): drive family 'generic_402' offers no access to vendor parameters"),
    (ParamSave, 'param_save', {'node_id': 2}, "node 2 (base_drive): drive family 'generic_402' offers no access"),
    (ParamRead, 'param_read', {'node_id': 50, 'parameter': 'DRV.ACC'},
     'node 50 is not in the bus configuration (configured: 2 (base_drive), 1 (akd))'),
    (ParamRead, 'param_read', {'parameter': 'DRV.ACC'}, 'no target: give a joint, or a node_id'),
    (ParamWrite, 'param_write', {'node_id': 1, 'parameter': 'DRV.STOP', 'value': ''},
     'DRV.STOP: the drive refused'),
])
def test_errors_are_named(setup: tuple[RosHarness, BusNode], srv: Any, name: str, fields: dict[str, Any],
                          reason: str) -> None:
    ros, _bridge = setup
    response = call(ros, srv, name, **fields)
    assert not response.success
    assert reason in response.message, response.message


def test_safety_parameters_and_objects_are_closed_to_clients_by_default(setup: tuple[RosHarness, BusNode]) -> None:
    """The AKD's FBUS.PARAM01 (bit rate) and FBUS.PARAM04 (SYNC supervision) decide its link and
    its reaction to a lost master: refused by access.safety_objects under either name, nothing
    written (issue 20)."""
    from drive_bridge_interfaces.msg import SdoValue
    from drive_bridge_interfaces.srv import SdoWrite
    ros, bridge = setup
    drive = bridge.simulation.drive(1)
    before = drive.value(0x36E5), drive.value(0x36E8)
    for parameter in ('FBUS.PARAM01', 'fbus.param04'):
        refused = call(ros, ParamWrite, 'param_write', joint='joint1', parameter=parameter, value='500')
        assert not refused.success and 'access.safety_objects' in refused.message, refused.message
        assert parameter.upper() in refused.message
    refused = call(ros, SdoWrite, 'sdo_write', node_id=1, index=0x36E5, subindex=0,
                   value=SdoValue(data_type=SdoValue.UNSIGNED32, uint_value=500))
    assert not refused.success and 'access.safety_objects' in refused.message and 'FBUS.PARAM01' in refused.message
    assert (drive.value(0x36E5), drive.value(0x36E8)) == before


@pytest.mark.parametrize('text', ['nan', 'inf', '-inf', '1e300', '-1e300'])
def test_a_non_finite_or_huge_number_as_text_is_refused_naming_it(setup: tuple[RosHarness, BusNode],
                                                                  text: str) -> None:
    ros, bridge = setup
    drive = bridge.simulation.drive(1)
    before = drive.value(0x3501)
    for parameter in ('DRV.ACC', 'MOTOR.ICONT'):  # an integer and a decimal parameter
        refused = call(ros, ParamWrite, 'param_write', joint='joint1', parameter=parameter, value=text)
        assert not refused.success and parameter in refused.message, (parameter, text, refused.message)
    assert drive.value(0x3501) == before
