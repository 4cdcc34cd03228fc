"""A drive supervised by node guarding, seen through ROS alone: its joint is in
``/joint_states`` while it answers, leaves it (and ``~/axis_states`` says unavailable, with
the drive-independent state) when it stops answering, a ``/rosout`` message names the node,
and when it answers again it is configured again but not re-enabled."""
from __future__ import annotations

import time
from typing import Any

from drive_bridge_interfaces.msg import AxisState, AxisStates
from rcl_interfaces.msg import Log
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from bridgetools import bridge_with_sim
from rostools import RosHarness, wait_for

NS = '/drive_bridge'
NODE = 7
JOINT = 'gripper_joint'


def config_data() -> dict[str, Any]:
    return {
        'bus': {'interface': 'virtual', 'channel': 'guardros'},  # bridgetools: a local channel of its own
        'master': {'sync_period': 4000},
        'nodes': {'gripper': {'node_id': NODE, 'family': 'generic_402', 'guard_time_ms': 50,
                              'life_time_factor': 3, 'axes': [{'joint': JOINT}]}},
        'simulation': {'enabled': True, 'nodes': {'gripper': {'heartbeat': False}}},
    }


def test_guarded_joint_leaves_joint_states_when_the_drive_stops_answering(ros: RosHarness) -> None:
    with bridge_with_sim(ros, config_data(), [Parameter('auto_enable', value=True)]) as node:
        states: list[JointState] = []
        axis_states: list[AxisStates] = []
        logs: list[Log] = []
        watcher = ros.node('guard_watch')
        watcher.create_subscription(JointState, '/joint_states', states.append, 100)
        watcher.create_subscription(AxisStates, f'{NS}/axis_states', axis_states.append, 100)
        watcher.create_subscription(Log, '/rosout', logs.append, 100)
        wait_for(lambda: any(JOINT in m.name for m in states), 10, f'{JOINT} in /joint_states')
        wait_for(lambda: axis_states and axis_states[-1].axes[0].drive_state == AxisState.DRIVE_ENABLED,
                 10, 'drive state enabled (auto_enable)')
        node.simulation.drive(NODE).stop_guarding_replies(True)
        lost = wait_for(lambda: next((m for m in logs if 'guarding' in m.msg and 'lost' in m.msg), None),
                        3, 'a guarding-lost log')
        assert lost.level == Log.ERROR and f'node {NODE}' in lost.msg and 'gripper' in lost.msg
        time.sleep(0.2)
        count = len(states)
        time.sleep(0.3)
        assert all(JOINT not in m.name for m in states[count:]), 'the lost joint is still published'
        last = wait_for(lambda: axis_states[-1].axes[0] if not axis_states[-1].axes[0].available else None,
                        2, 'axis state unavailable')
        assert last.drive_state == AxisState.DRIVE_UNAVAILABLE and last.drive_state_name == 'unavailable'
        node.simulation.drive(NODE).stop_guarding_replies(False)
        wait_for(lambda: any(JOINT in m.name for m in states[count:]), 10, f'{JOINT} back in /joint_states')
        back = wait_for(lambda: axis_states[-1].axes[0] if axis_states[-1].axes[0].available else None,
                        5, 'axis available again')
        time.sleep(0.3)
        assert axis_states[-1].axes[0].drive_state != AxisState.DRIVE_ENABLED, 're-enabled by itself'
        assert back.joint_name == JOINT
