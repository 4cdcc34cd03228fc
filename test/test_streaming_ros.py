"""Trajectory streaming through ROS: control_msgs' FollowJointTrajectory action (as MoveIt
sends it, and what the bridge refuses of it), interpolated position (linear), replacement,
stopping with deceleration."""
from __future__ import annotations

import math
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointComponentTolerance, JointTolerance
from drive_bridge_interfaces.srv import SetMode
from geometry_msgs.msg import Transform
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import (
    JointTrajectory,
    JointTrajectoryPoint,
    MultiDOFJointTrajectory,
    MultiDOFJointTrajectoryPoint,
)

from bridgetools import bridge_with_sim
from bustools import demo_data
from drive_bridge.cia402.statemachine import State
from drive_bridge.ros.frames import stamp_from_seconds
from drive_bridge.ros.node import BusNode
from rostools import ActionClient, RosHarness, wait_for

NS = '/drive_bridge'
Result = FollowJointTrajectory.Result


@pytest.fixture
def bridge(ros: RosHarness):
    with bridge_with_sim(ros, demo_data(), [Parameter('auto_enable', value=True)]) as node:  # drives in the test
        node.master.wait_until_operational(10.0)
        wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10, 'enabled')
        yield node


def point(t: float, positions, velocities=()) -> JointTrajectoryPoint:
    return JointTrajectoryPoint(positions=list(positions), velocities=list(velocities),
                                time_from_start=Duration(sec=int(t), nanosec=round((t % 1) * 1e9)))


class Goal:
    """One action goal: send, collect feedback, await the result."""

    def __init__(self, ros: RosHarness, client: ActionClient, trajectory: JointTrajectory, **fields) -> None:
        self.ros = ros
        self.feedback: list = []
        goal = FollowJointTrajectory.Goal(trajectory=trajectory, **fields)
        sent = client.send_goal_async(goal, feedback_callback=lambda f: self.feedback.append(f.feedback))
        self.handle = wait_for(lambda: sent.result() if sent.done() else None, 10, 'goal response')
        assert self.handle.accepted
        self._result = self.handle.get_result_async()

    def result(self, timeout: float = 15.0):
        return wait_for(lambda: self._result.result() if self._result.done() else None, timeout, 'result').result

    def cancel(self) -> None:
        future = self.handle.cancel_goal_async()
        wait_for(lambda: future.done(), 5, 'cancel response')


@pytest.fixture
def action(ros: RosHarness) -> ActionClient:
    client = ActionClient(ros.node('action_client'), FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
    assert client.wait_for_server(timeout_sec=10)
    return client


def test_action_executes_with_feedback_and_tolerances(ros, bridge, action) -> None:
    start = {j: bridge.master.axes[j].snapshot().position for j in ('base_joint', 'elbow_joint')}
    trajectory = JointTrajectory(joint_names=list(start), points=[
        point(0.5, [start['base_joint'] + 0.2, start['elbow_joint'] - 0.1], [0.3, -0.15]),
        point(1.0, [start['base_joint'] + 0.3, start['elbow_joint'] - 0.2], [0.0, 0.0])])
    goal = Goal(ros, action, trajectory,
                path_tolerance=[JointTolerance(name='base_joint', position=0.05)],
                goal_tolerance=[JointTolerance(name='base_joint', position=0.002),
                                JointTolerance(name='elbow_joint', position=0.002)])
    result = goal.result()
    assert (result.error_code, result.error_string) == (Result.SUCCESSFUL, '')
    assert len(goal.feedback) >= 3  # feedback as it goes (fewer on a busy machine)
    middle = goal.feedback[len(goal.feedback) // 2]
    assert list(middle.joint_names) == ['base_joint', 'elbow_joint']
    for i in range(2):
        assert middle.error.positions[i] == pytest.approx(middle.desired.positions[i] - middle.actual.positions[i])
        assert abs(middle.error.positions[i]) < 0.05
    assert bridge.master.axes['base_joint'].snapshot().position == pytest.approx(start['base_joint'] + 0.3, abs=2e-3)


def test_action_result_codes(ros, bridge, action) -> None:
    invalid = Goal(ros, action, JointTrajectory(joint_names=['nope'], points=[point(1, [0.0])])).result()
    assert invalid.error_code == Result.INVALID_JOINTS and 'nope' in invalid.error_string
    bad = Goal(ros, action, JointTrajectory(joint_names=['base_joint'], points=[point(1, [9.0])])).result()
    assert bad.error_code == Result.INVALID_GOAL and 'above its limit' in bad.error_string
    old = JointTrajectory(joint_names=['base_joint'], points=[point(0.1, [0.0])])
    old.header.stamp = stamp_from_seconds(time.time() - 10)
    assert Goal(ros, action, old).result().error_code == Result.OLD_HEADER_TIMESTAMP
    here = bridge.master.axes['base_joint'].snapshot().position
    tight = Goal(ros, action, JointTrajectory(joint_names=['base_joint'], points=[point(1.0, [here + 0.5])]),
                 path_tolerance=[JointTolerance(name='base_joint', position=1e-6)]).result()
    assert tight.error_code == Result.PATH_TOLERANCE_VIOLATED
    assert 'path tolerance violated: base_joint position error' in tight.error_string


def test_cancel_stops_with_deceleration_and_a_new_goal_replaces_the_old(ros, bridge, action) -> None:
    axis = bridge.master.axes['base_joint']
    here = axis.snapshot().position
    first = Goal(ros, action, JointTrajectory(joint_names=['base_joint'], points=[point(3.0, [here + 1.5])]))
    time.sleep(0.8)
    second = Goal(ros, action, JointTrajectory(joint_names=['base_joint'], points=[point(3.0, [here - 1.0])]))
    replaced = first.result()
    assert replaced.error_code == Result.INVALID_GOAL and 'replaced by trajectory' in replaced.error_string
    time.sleep(0.8)
    moving = abs(axis.snapshot().velocity)
    assert moving > 0.1
    second.cancel()
    speeds = []
    for _ in range(30):
        speeds.append(abs(axis.snapshot().velocity))
        time.sleep(0.01)
    assert speeds[5] > 0.05, 'stopped instantly instead of decelerating'
    wait_for(lambda: abs(axis.snapshot().velocity) < 1e-3, 5, 'standstill after cancel')
    assert second.result().error_string.startswith('cancelled')


def test_empty_trajectory_on_the_topic_stops_with_deceleration(ros, bridge) -> None:
    axis = bridge.master.axes['shoulder_joint']
    here = axis.snapshot().position
    publisher = ros.node('topic_pub').create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    time.sleep(0.3)
    publisher.publish(JointTrajectory(joint_names=['shoulder_joint'], points=[point(2.0, [here + 1.2])]))
    wait_for(lambda: abs(axis.snapshot().velocity) > 0.3, 3, 'moving')
    velocity = axis.snapshot().velocity
    publisher.publish(JointTrajectory(joint_names=['shoulder_joint']))
    wait_for(lambda: abs(axis.snapshot().velocity) < 1e-3, 5, 'stopped')
    stopped_at = axis.snapshot().position
    deceleration = axis.stop_deceleration()
    # travel after the stop request ~ v^2 / 2a (plus what was moving while the message crossed)
    assert stopped_at - here > velocity ** 2 / (2 * deceleration) * 0.5
    assert not bridge.trajectories.active()


def test_interpolated_position_linear_follows_the_path(ros, bridge) -> None:
    states: list[JointState] = []
    ros.node('ip_states').create_subscription(JointState, '/joint_states', states.append, 1000)
    client = ros.node('ip_mode').create_client(SetMode, f'{NS}/set_mode')
    response = ros.call(client, SetMode.Request(joints=['base_joint'], mode='ip'))
    assert response.success, response.message
    assert bridge.trajectories.strategy('base_joint') == 'ip-linear'
    sim_axis = bridge.simulation.drive(2).axis(0)
    here = bridge.master.axes['base_joint'].snapshot().position
    start = time.time() + 0.3
    trajectory = JointTrajectory(joint_names=['base_joint'], points=[
        point(0.6, [here + 0.15], [0.4]), point(1.2, [here + 0.3], [0.0])])
    trajectory.header.stamp = stamp_from_seconds(start)
    publisher = ros.node('ip_pub').create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    time.sleep(0.2)
    publisher.publish(trajectory)
    time.sleep(1.8)
    assert sim_axis.mode == 7 and sim_axis.statusword & 0x1000  # IP active on the drive
    assert sim_axis.ip.overflows == 0
    wait_for(lambda: abs(dict(zip(states[-1].name, states[-1].position))['base_joint'] - (here + 0.3)) < 2e-3,
             3, 'the goal in IP mode')


def test_diagnostics_report_sync_timing_and_setpoint_lead(ros, bridge) -> None:
    from diagnostic_msgs.msg import DiagnosticArray
    reports: list[DiagnosticArray] = []
    ros.node('diag_watch').create_subscription(DiagnosticArray, '/diagnostics', reports.append, 10)
    report = wait_for(lambda: next((r for r in reversed(reports) if r.status), None), 5, 'diagnostics')
    bus = next(s for s in report.status if s.name.startswith('drive_bridge: bus'))
    values = {kv.key: kv.value for kv in bus.values}
    assert values['sync_period'] == '4.00 ms'
    lead = float(values['setpoint_lead_median'].split()[0])
    assert 0.0 < lead < 4.0  # ms: the RPDOs go out before the SYNC that latches them
    assert float(values['frames_per_second']) > 100  # about 2,500 (fewer on a busy machine)
    for key in ('sync_interval_p99', 'sync_jitter_max', 'setpoint_lead_max', 'sync_skipped', 'bus_load'):
        assert key in values
    assert values['late_setpoints'] == '0'  # no master.sync_window: no set-point is ever too late


MOVEIT_CONTROLLERS = Path(__file__).resolve().parents[1] / 'examples' / 'moveit' / 'moveit_controllers.yaml'


def moveit_goal(joints: list[str], start: dict[str, float], step: float) -> FollowJointTrajectory.Goal:
    """The goal MoveIt's FollowJointTrajectory controller handle sends: a time-parameterised
    trajectory of every controller joint from the present state (point 0 at t = 0, positions,
    velocities and accelerations), header stamp 0 (start now), an empty multi-DOF trajectory,
    no tolerances (its goal template)."""
    points = []
    for i in range(11):  # a smooth rest-to-rest move over 1 s
        t = i / 10
        s, ds, dds = (10 * t**3 - 15 * t**4 + 6 * t**5, 30 * t**2 - 60 * t**3 + 30 * t**4,
                      60 * t - 180 * t**2 + 120 * t**3)
        points.append(JointTrajectoryPoint(positions=[start[j] + step * s for j in joints],
                                           velocities=[step * ds for _ in joints],
                                           accelerations=[step * dds for _ in joints],
                                           time_from_start=Duration(sec=int(t), nanosec=round((t % 1) * 1e9))))
    return FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=joints, points=points))


def test_a_moveit_client_of_control_msgs_type_executes_on_the_demo(ros, bridge) -> None:
    config = yaml.safe_load(MOVEIT_CONTROLLERS.read_text())
    (name,) = config['moveit_simple_controller_manager']['controller_names']
    controller = config['moveit_simple_controller_manager'][name]
    assert controller['type'] == 'FollowJointTrajectory'
    joints = controller['joints']
    assert sorted(joints) == sorted(bridge.master.axes)  # the controller is the whole bus
    # MoveIt's action name: <controller name>/<action_ns>, in move_group's (root) namespace
    client = ActionClient(ros.node('move_group'), FollowJointTrajectory, f'/{name}/{controller["action_ns"]}')
    assert client.wait_for_server(timeout_sec=10)
    start = {j: bridge.master.axes[j].snapshot().position for j in joints}
    step = 0.05
    goal = Goal(ros, client, moveit_goal(joints, start, step).trajectory)
    result = goal.result()
    assert (result.error_code, result.error_string) == (Result.SUCCESSFUL, '')
    assert goal.feedback and list(goal.feedback[-1].joint_names) == joints
    assert list(goal.feedback[-1].multi_dof_joint_names) == []
    for joint in joints:
        assert bridge.master.axes[joint].snapshot().position == pytest.approx(start[joint] + step, abs=3e-3), joint


def test_goals_the_bridge_cannot_execute_are_refused_with_the_reason(ros, bridge, action) -> None:
    here = bridge.master.axes['base_joint'].snapshot().position
    moving = JointTrajectory(joint_names=['base_joint'], points=[point(0.5, [here + 0.01])])
    multi = FollowJointTrajectory.Goal(trajectory=moving)
    multi.multi_dof_trajectory = MultiDOFJointTrajectory(
        joint_names=['mobile_base'], points=[MultiDOFJointTrajectoryPoint(transforms=[Transform()])])
    cases = [
        (multi, Result.INVALID_GOAL, "multi_dof_trajectory has 1 joint(s) ('mobile_base') and 1 point(s): this "
                                     'bridge drives single-DOF joints only'),
        (FollowJointTrajectory.Goal(trajectory=moving, component_path_tolerance=[
            JointComponentTolerance(joint_name='mobile_base', component=JointComponentTolerance.TRANSLATION,
                                    position=0.01)]),
         Result.INVALID_GOAL, "component_path_tolerance bounds joint(s) 'mobile_base': component tolerances are "
                              'for multi-DOF joints'),
        (FollowJointTrajectory.Goal(trajectory=moving, goal_tolerance=[
            JointTolerance(name='base_joint', acceleration=0.1)]),
         Result.INVALID_GOAL, 'goal_tolerance: acceleration tolerance 0.1 of base_joint cannot be checked'),
        (FollowJointTrajectory.Goal(trajectory=moving, path_tolerance=[
            JointTolerance(name='base_joint', position=math.nan)]),
         Result.INVALID_GOAL, 'path_tolerance: position tolerance of base_joint is NaN'),
        (FollowJointTrajectory.Goal(trajectory=moving, path_tolerance=[JointTolerance(name='nope', position=0.1)]),
         Result.INVALID_JOINTS, "path_tolerance names joint(s) 'nope', not joints of this bus"),
    ]
    for request, code, reason in cases:
        sent = action.send_goal_async(request)
        handle = wait_for(lambda: sent.result() if sent.done() else None, 10, 'goal response')
        future = handle.get_result_async()
        result = wait_for(lambda: future.result() if future.done() else None, 10, 'result').result
        assert result.error_code == code and reason in result.error_string, (reason, result.error_string)
    assert not bridge.trajectories.active(), 'nothing of a refused goal runs'
    # a multi-DOF trajectory that is empty and component tolerances that check nothing (0 = the
    # default, -1 = none) are what MoveIt sends for a robot without multi-DOF joints: accepted
    accepted = Goal(ros, action, moving, component_goal_tolerance=[
        JointComponentTolerance(joint_name='base_joint', component=JointComponentTolerance.ROTATION, position=-1.0)])
    assert accepted.result().error_code == Result.SUCCESSFUL


def test_the_documented_action_example_runs_against_the_demo(ros) -> None:
    """docs/interfaces.md's Python call example, as a client process of its own. The demo with
    1 s heartbeat timeouts (multiplier 10), as test_setup's README example: a process starting
    beside it on a busy machine stalled the bridge's process 0.5 s and faulted its drives."""
    data = demo_data()
    data.setdefault('options', {})['heartbeat_multiplier'] = 10
    bridge = BusNode(context=ros.context, parameter_overrides=[
        Parameter('config_yaml', value=yaml.safe_dump(data, sort_keys=False)), Parameter('auto_enable', value=True)])
    ros.add(bridge)
    try:
        wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in bridge.master.axes.values()), 15, 'enabled')
        text = (Path(__file__).resolve().parents[1] / 'docs' / 'interfaces.md').read_text()
        section = text.split('## The trajectory action', 1)[1].split('\n## ', 1)[0]
        (example,) = re.findall(r'```python\n(.*?)```', section, re.S)
        run = subprocess.run([sys.executable, '-c', example], capture_output=True, text=True, timeout=120)
        assert run.returncode == 0, run.stderr[-2000:]
        assert run.stdout.strip().splitlines()[-1] == '0', run.stdout
        assert bridge.master.axes['base_joint'].snapshot().position == pytest.approx(0.0, abs=0.01)
    finally:
        bridge.close()
