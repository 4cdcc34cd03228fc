"""The bus node's ROS parameters at run time, through the standard parameter services.

Start-time parameters (sync_period, command_interface, simulate, ...) are refused on the running
node with the reason; run-time ones (publish_rate, diagnostics_period, pvt_*) are validated and
applied, which the topics show. The lifecycle node takes anything while unconfigured, reads it
at configure, and guards the start-time ones from then until cleanup.
"""
from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from drive_bridge_interfaces.msg import AxisStates
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically
from rclpy.parameter import Parameter, parameter_value_to_python
from sensor_msgs.msg import JointState

from bustools import demo_data
from drive_bridge.ros.lifecycle import BusLifecycleNode
from drive_bridge.ros.node import BusNode
from drive_bridge.ros.parameters import RUN_TIME, START_TIME
from rostools import RosHarness, ros_harness, wait_for
from timingtools import CycleWatch, stamped_count

INTERFACES_DOC = Path(__file__).resolve().parent.parent / 'docs' / 'interfaces.md'


def demo_yaml() -> str:
    return yaml.safe_dump(demo_data(), sort_keys=False)


class ParameterClient:
    """SetParameters / GetParameters of one node, as `ros2 param set` calls them."""

    def __init__(self, ros: RosHarness, node_name: str) -> None:
        self.ros = ros
        client = ros.node(f'{node_name}_param_client')
        self.set_client = client.create_client(SetParameters, f'/{node_name}/set_parameters')
        self.atomic_client = client.create_client(SetParametersAtomically, f'/{node_name}/set_parameters_atomically')
        self.get_client = client.create_client(GetParameters, f'/{node_name}/get_parameters')

    def set(self, name: str, value: Any) -> Any:
        request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
        return self.ros.call(self.set_client, request).results[0]

    def set_together(self, **values: Any) -> Any:
        request = SetParametersAtomically.Request(
            parameters=[Parameter(name, value=value).to_parameter_msg() for name, value in values.items()])
        return self.ros.call(self.atomic_client, request).result

    def get(self, name: str) -> Any:
        return parameter_value_to_python(self.ros.call(self.get_client, GetParameters.Request(names=[name])).values[0])


def rate(messages: list[Any], seconds: float) -> float:
    """Messages per second stamped over the next ``seconds`` (by their header stamps: a backlog
    delivered after a stall of this busy machine is not counted in the new rate)."""
    start = time.time()
    time.sleep(seconds)
    end = time.time()
    time.sleep(0.3)  # what was published in the window arrives
    return stamped_count(messages, start, end) / (end - start)


def per_cycle(messages: list[Any], node: BusNode, seconds: float) -> float:
    """Messages stamped over the next ``seconds`` per SYNC cycle the bridge ran meanwhile."""
    watch, start = CycleWatch(node.master), time.time()
    time.sleep(seconds)
    cycles, end = watch.cycles, time.time()
    time.sleep(0.3)
    return stamped_count(messages, start, end) / max(1, cycles)


@pytest.fixture(scope='module')
def running() -> Iterator[tuple[RosHarness, BusNode, ParameterClient]]:
    with ros_harness() as ros:
        node = BusNode(context=ros.context, node_name='params_bridge',
                       parameter_overrides=[Parameter('config_yaml', value=demo_yaml())])
        ros.add(node)
        try:
            node.master.wait_until_operational(15.0)
            yield ros, node, ParameterClient(ros, 'params_bridge')
        finally:
            node.close()


def test_the_interfaces_doc_lists_every_parameter_with_its_class() -> None:
    text = INTERFACES_DOC.read_text(encoding='utf-8').split('\n## Parameters\n', 1)[1].split('\n## ', 1)[0]
    rows = dict(re.findall(r'^\| `(\w+)` \| (start|run) time \|', text, re.M))
    assert rows == {**{name: 'start' for name in START_TIME}, **{name: 'run' for name in RUN_TIME}}


@pytest.mark.parametrize('name, value', [('sync_period', 0.0005), ('command_interface', 'effort'),
                                         ('simulate', False), ('config_yaml', 'nodes: {}'), ('qos_depth', 1)])
def test_start_time_parameters_are_refused_while_running(running: tuple[RosHarness, BusNode, ParameterClient],
                                                         name: str, value: Any) -> None:
    _ros, node, client = running
    before = client.get(name)
    result = client.set(name, value)
    assert not result.successful
    assert result.reason.startswith(f'{name}: acts only at start, read-only while the node runs; restart')
    assert 'Changeable at run time: diagnostics_period, publish_rate' in result.reason
    assert client.get(name) == before
    assert node.master.config.master.sync_period == 0.004


@pytest.mark.slow
def test_run_time_parameters_are_validated_and_applied(running: tuple[RosHarness, BusNode, ParameterClient]) -> None:
    ros, node, client = running
    listener = ros.node('params_listener')
    states: list[JointState] = []
    diagnostics: list[DiagnosticArray] = []
    axis_states: list[AxisStates] = []
    listener.create_subscription(AxisStates, '/params_bridge/axis_states', axis_states.append, 100)
    listener.create_subscription(JointState, '/joint_states', states.append, 100)
    listener.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 100)
    wait_for(lambda: len(states) > 20, 10, 'joint states')
    # the rates: upper bounds as set, lower bounds only that it publishes (a busy machine slows
    # timers and cycles down, never up)
    assert per_cycle(states, node, 1.0) > 0.5  # one per SYNC (4 ms: about 250 Hz)

    assert client.set('publish_rate', 20.0).successful
    assert client.get('publish_rate') == 20.0
    slowed = rate(states, 1.5)
    assert 2 < slowed < 30, slowed
    assert client.set('diagnostics_period', 0.1).successful
    time.sleep(0.3)
    assert rate(diagnostics, 1.5) > 2  # was 1 Hz, now 10
    assert client.set('state_rate', 0.0).successful  # on change only: the axes stand still
    time.sleep(0.3)
    assert rate(axis_states, 1.0) < 3
    assert client.set('state_rate', 40.0).successful
    time.sleep(0.2)
    assert rate(axis_states, 1.0) > 5  # 40 Hz, where on change alone gives none

    flood = client.set('diagnostics_period', 1e-6)
    assert not flood.successful
    assert flood.reason == 'parameter diagnostics_period must be a finite number in 0.05..3600, got 1e-06'
    assert not client.set('state_rate', 5000.0).successful
    negative = client.set('publish_rate', -5.0)
    assert not negative.successful
    assert negative.reason == 'parameter publish_rate must be 0 or a finite number in 0.1..1000, got -5.0'
    short = client.set('pvt_lookahead', 0.005)
    assert not short.successful and 'pvt_lookahead must be >= pvt_segment, got 0.005' in short.reason
    assert client.set('pvt_segment', 0.02).successful and client.set('pvt_lookahead', 0.08).successful
    assert (node.trajectories.pvt_segment, node.trajectories.pvt_lookahead) == (0.02, 0.08)
    odd = client.set('pvt_segment', 0.0125)
    assert not odd.successful and 'whole number of ms' in odd.reason
    mixed = client.set_together(publish_rate=50.0, sync_period=0.008)
    assert not mixed.successful and mixed.reason.startswith('sync_period: acts only at start')
    assert client.get('publish_rate') == 20.0  # nothing of a refused atomic set is applied
    assert client.set('publish_rate', 0.0).successful and client.set('diagnostics_period', 1.0).successful
    assert client.set('state_rate', 10.0).successful
    assert per_cycle(states, node, 1.0) > 0.5


def test_lifecycle_node_takes_parameters_until_configured_and_again_after_cleanup() -> None:
    with ros_harness() as ros:
        node = BusLifecycleNode(context=ros.context, node_name='params_managed',
                                parameter_overrides=[Parameter('config_yaml', value=demo_yaml())])
        ros.add(node)
        client = ParameterClient(ros, 'params_managed')
        change = ros.node('params_managed_tester').create_client(ChangeState, '/params_managed/change_state')

        def transition(transition_id: int) -> bool:
            return bool(ros.call(change, ChangeState.Request(transition=Transition(id=transition_id))).success)
        try:
            assert client.set('sync_period', 0.008).successful  # unconfigured: read at configure
            assert transition(Transition.TRANSITION_CONFIGURE)
            assert node.bridge is not None and node.bridge.master.config.master.sync_period == 0.008
            refused = client.set('sync_period', 0.002)
            assert not refused.successful and refused.reason.startswith('sync_period: acts only at start')
            assert client.set('publish_rate', 10.0).successful  # run-time: applied while configured
            assert transition(Transition.TRANSITION_CLEANUP)
            assert client.set('sync_period', 0.002).successful
            assert client.set('publish_rate', -1.0).successful  # checked at configure, which refuses it
            assert not transition(Transition.TRANSITION_CONFIGURE)
            assert node.bridge is None
        finally:
            node.close()
