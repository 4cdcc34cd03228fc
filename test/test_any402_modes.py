"""Modes from the drive's 0x6502, through ROS: an axis whose configured mode the drive lacks,
and one whose drive has no mode the bridge can stream, refuse trajectories and commands with
the reason (on ~/command_errors and in the action result), instead of accepting and dropping
them; a drive without csp streams in the mode it has (test_any402.py: technosoft.eds in ip)."""
from __future__ import annotations

import math
import threading
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from configtools import REAL_EDS
from drive_bridge.cia402.statemachine import State
from drive_bridge.ros.node import BusNode
from rostools import ActionClient, RosHarness, wait_for

NS = '/drive_bridge'
SCALE = {'scale_pos_from_dev': 2 * math.pi / 2000}
Result = FollowJointTrajectory.Result


def torque_only_eds(tmp_path: Path) -> Path:
    """technosoft.eds with 0x6502 saying profile torque only: nothing the bridge can stream."""
    text = (REAL_EDS / 'technosoft.eds').read_text(encoding='latin-1')
    start = text.index('[6502]')
    end = text.index('[', start + 1)
    section = text[start:end].replace('DefaultValue=0x001F0065', 'DefaultValue=0x00000008')
    assert section != text[start:end], 'the fixture expects technosoft.eds 0x6502 = 0x1F0065'
    path = tmp_path / 'torque_only.eds'
    path.write_text(text[:start] + section + text[end:], encoding='latin-1')
    return path


@pytest.fixture
def bridge(ros: RosHarness, tmp_path: Path):
    config = {'bus': {'channel': 'any402_modes'}, 'master': {'sync_period': 4000},
              'nodes': {'ipos_csp': {'dcf': str(REAL_EDS / 'technosoft.eds'), 'node_id': 2, 'position_mode': 'csp',
                                     **SCALE},
                        'torque_only': {'dcf': str(torque_only_eds(tmp_path)), 'node_id': 3, **SCALE}},
              'simulation': {'enabled': True}}
    node = BusNode(context=ros.context, parameter_overrides=[
        Parameter('config_yaml', value=yaml.safe_dump(config, sort_keys=False)),
        Parameter('auto_enable', value=True), Parameter('command_joints', value=['ipos_csp'])])
    ros.add(node)
    wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10, 'enabled')
    yield node
    node.close()


def test_axes_without_a_usable_mode_refuse_with_the_reason(ros: RosHarness, bridge: BusNode) -> None:
    client = ros.node('any402_modes_client')
    errors: list[str] = []
    lock = threading.Lock()

    def on_error(msg: String) -> None:
        with lock:
            errors.append(msg.data)
    client.create_subscription(String, f'{NS}/command_errors', on_error, 50)
    trajectories = client.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    commands = client.create_publisher(Float64MultiArray, f'{NS}/commands', 10)
    wait_for(lambda: trajectories.get_subscription_count() and commands.get_subscription_count(), 10, 'discovery')
    csp_reason = ("axis 'ipos_csp' (node 2 ipos_csp, slot 0): the configured mode csp is not supported by the "
                  'drive (0x6502 = 0x001F0065: pp, pv, hm, ip); set another mode (axis key `mode`)')
    none_reason = ("axis 'torque_only' (node 3 torque_only, slot 0): no mode the bridge can stream: the drive has "
                   '0x6502 = 0x00000008: pt, its PDO map streams csp, ip, pv')
    assert bridge.master.axes['torque_only'].snapshot().message == none_reason.split('): ', 1)[1]
    start = bridge.master.axes['ipos_csp'].snapshot().position
    point = JointTrajectoryPoint(positions=[start + 0.1], time_from_start=Duration(sec=1))

    def refused(text: str) -> bool:
        with lock:
            return text in errors
    trajectories.publish(JointTrajectory(joint_names=['ipos_csp'], points=[point]))
    wait_for(lambda: refused(f'~/joint_trajectory: refused: {csp_reason}'), 5, 'the csp refusal')
    trajectories.publish(JointTrajectory(joint_names=['torque_only'], points=[point]))
    wait_for(lambda: refused(f'~/joint_trajectory: refused: {none_reason}'), 5, 'the no-mode refusal')
    commands.publish(Float64MultiArray(data=[start + 0.1]))
    wait_for(lambda: refused(f'~/commands: refused: {csp_reason}'), 5, 'the command refusal')
    action = ActionClient(client, FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
    assert action.wait_for_server(timeout_sec=10)
    sent = action.send_goal_async(FollowJointTrajectory.Goal(
        trajectory=JointTrajectory(joint_names=['torque_only'], points=[point])))
    handle = wait_for(lambda: sent.result() if sent.done() else None, 10, 'goal response')
    future = handle.get_result_async()
    result = wait_for(lambda: future.result() if future.done() else None, 10, 'result').result
    assert result.error_code == Result.INVALID_GOAL and none_reason in result.error_string
    # nothing moved
    assert bridge.master.axes['ipos_csp'].snapshot().position == pytest.approx(start, abs=1e-3)
