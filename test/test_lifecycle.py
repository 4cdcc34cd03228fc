"""The managed bus node: configure boots without enabling, activate starts, deactivate halts."""
from __future__ import annotations

import time

import yaml
from drive_bridge_interfaces.srv import AxisCommand
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

from bridgetools import bridge_with_sim
from bustools import demo_data
from drive_bridge.cia402.statemachine import State
from drive_bridge.ros.lifecycle import BusLifecycleNode
from rostools import RosHarness, wait_for

NS = '/drive_bridge'


def transition(ros: RosHarness, client, transition_id: int) -> bool:
    return ros.call(client, ChangeState.Request(transition=Transition(id=transition_id))).success


def test_lifecycle_transitions_boot_start_halt_and_release(ros: RosHarness) -> None:
    with bridge_with_sim(ros, demo_data(), lifecycle=True) as node:  # the drives in this process, on its bus
        tester = ros.node('lifecycle_tester')
        change = tester.create_client(ChangeState, f'{NS}/change_state')
        get = tester.create_client(GetState, f'{NS}/get_state')
        states: list[JointState] = []
        errors: list[String] = []
        tester.create_subscription(JointState, '/joint_states', states.append, 100)
        tester.create_subscription(String, f'{NS}/command_errors', errors.append, 100)

        assert transition(ros, change, Transition.TRANSITION_CONFIGURE)
        assert ros.call(get, GetState.Request()).current_state.label == 'inactive'
        node.bridge.master.wait_until_operational(10)
        bus_process = node.bridge.master.process  # configure started the bus process, the node's child
        assert bus_process is not None and bus_process.poll() is None
        axes = node.bridge.master.axes
        assert all(a.state is State.SWITCH_ON_DISABLED for a in axes.values())  # booted, not enabled
        time.sleep(0.3)
        assert not states  # inactive: nothing published

        assert transition(ros, change, Transition.TRANSITION_ACTIVATE)
        wait_for(lambda: states, 5, 'joint states once active')
        enable = tester.create_client(AxisCommand, f'{NS}/enable')
        assert ros.call(enable, AxisCommand.Request()).success
        assert all(a.state is State.OPERATION_ENABLED for a in axes.values())

        assert transition(ros, change, Transition.TRANSITION_DEACTIVATE)
        sim = node.simulation
        wait_for(lambda: sim.drive(2).axis(0).controlword & 0x100, 3, 'HALT bit after deactivate')
        assert axes['base_joint'].state is State.OPERATION_ENABLED  # halted, still enabled
        commands = tester.create_publisher(Float64MultiArray, f'{NS}/commands', 10)
        time.sleep(0.3)
        commands.publish(Float64MultiArray(data=[0.1, 0.1, 0.1, 0.1]))
        refused = wait_for(lambda: errors, 3, 'refusal while inactive')
        assert 'not active' in refused[-1].data

        assert transition(ros, change, Transition.TRANSITION_ACTIVATE)
        wait_for(lambda: not sim.drive(2).axis(0).controlword & 0x100, 3, 'HALT cleared on activate')

        assert transition(ros, change, Transition.TRANSITION_DEACTIVATE)
        assert transition(ros, change, Transition.TRANSITION_CLEANUP)
        assert node.bridge is None
        assert bus_process.poll() == 0  # cleanup ended the bus process (it released the bus)
        assert ros.call(get, GetState.Request()).current_state.label == 'unconfigured'
        assert transition(ros, change, Transition.TRANSITION_CONFIGURE)  # again, on a fresh bus
        node.bridge.master.wait_until_operational(10)
        assert node.bridge.master.pid != bus_process.pid  # in a bus process of its own


def test_configure_fails_cleanly_on_a_bad_configuration(ros: RosHarness) -> None:
    data = demo_data()
    data['nodes']['base_drive']['node_id'] = 3  # clashes with arm_drive
    node = BusLifecycleNode(context=ros.context, parameter_overrides=[
        Parameter('config_yaml', value=yaml.safe_dump(data, sort_keys=False))])
    ros.add(node)
    change = ros.node('lifecycle_tester2').create_client(ChangeState, f'{NS}/change_state')
    assert not transition(ros, change, Transition.TRANSITION_CONFIGURE)
    assert node.bridge is None
