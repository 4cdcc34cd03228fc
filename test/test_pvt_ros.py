"""PVT streaming through ROS against a simulated Kollmorgen AKD (config/akd_pvt_example.yaml):
the buffer is kept fed and never overflows, a starved stream underflows and is held until
resumed, a replacement splices and an empty trajectory decelerates to a stop."""
from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from drive_bridge_interfaces.msg import Emcy
from drive_bridge_interfaces.srv import AxisCommand
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bridgetools import bridge_with_sim
from drive_bridge.cia402.statemachine import State
from drive_bridge.ros.frames import stamp_from_seconds
from drive_bridge.streaming.trajectory import JointSample, Trajectory, TrajectoryPoint, joint_splines
from rostools import ActionClient, RosHarness, wait_for
from timingtools import BUSY_SLACK, assert_follows

NS = '/drive_bridge'
CONFIG = Path(__file__).resolve().parent.parent / 'config' / 'akd_pvt_example.yaml'
JOINT = 'joint1'
SEGMENT, LOOKAHEAD = 0.04, 0.2  # s: pvt_segment, pvt_lookahead


@pytest.fixture
def bridge(ros: RosHarness):
    data = yaml.safe_load(CONFIG.read_text())  # bridgetools: on a local bus, the AKD simulated in the test
    # the drive runs in this test's process, beside its ROS harness: on a busy 2-core machine a
    # stall of it (or of the bus process) over 300 ms lost the heartbeat (AKD F129, EMCY 0x8130)
    data.setdefault('options', {})['heartbeat_multiplier'] = 10
    # points 40 ms apart kept 200 ms ahead (as test_faults_overflow.py): at the defaults (10 ms,
    # 50 ms ahead) a bus process starved for 50 ms on a busy machine underflowed the buffer (EMCY
    # 0x8585, the axis then held until ~/resume, by design), which no test here intends
    params = [Parameter('auto_enable', value=True), Parameter('pvt_segment', value=SEGMENT),
              Parameter('pvt_lookahead', value=LOOKAHEAD)]
    with bridge_with_sim(ros, data, params) as node:
        node.master.wait_until_operational(10.0)
        axis = node.master.axes[JOINT]
        wait_for(lambda: axis.state is State.OPERATION_ENABLED, 10, 'enabled')
        axis.set_mode('ip', timeout=3.0)
        assert node.trajectories.strategy(JOINT) == 'pvt'
        yield node


def point(t: float, positions, velocities=()) -> JointTrajectoryPoint:
    return JointTrajectoryPoint(positions=list(positions), velocities=list(velocities),
                                time_from_start=Duration(sec=int(t), nanosec=round((t % 1) * 1e9)))


def recorders(ros: RosHarness):
    states: list[JointState] = []
    emcys: list[Emcy] = []
    node = ros.node(f'pvt_watch_{time.monotonic_ns() % 100000}')
    node.create_subscription(JointState, '/joint_states', states.append, 1000)
    node.create_subscription(Emcy, f'{NS}/emcy', emcys.append, 100)
    publisher = node.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    wait_for(lambda: states, 5, 'joint states')
    time.sleep(0.2)  # discovery of the publisher
    return states, emcys, publisher


def position_of(msg: JointState) -> float:
    return dict(zip(msg.name, msg.position))[JOINT]


def test_pvt_follows_the_path_and_never_overflows_the_buffer(ros, bridge) -> None:
    states, emcys, publisher = recorders(ros)
    here = position_of(states[-1])
    start = time.time() + 0.3
    msg = JointTrajectory(joint_names=[JOINT], points=[point(0.6, [here + 0.8], [1.5]),
                                                       point(1.2, [here + 1.2], [0.0])])
    msg.header.stamp = stamp_from_seconds(start)
    publisher.publish(msg)
    time.sleep(1.9)
    ideal = joint_splines(Trajectory((JOINT,), (TrajectoryPoint(0.6, (here + 0.8,), (1.5,)),
                                                TrajectoryPoint(1.2, (here + 1.2,), (0.0,)))),
                          start, {JOINT: JointSample(here, 0.0, 0.0)})[JOINT]
    errors = [abs(position_of(m) - ideal.sample(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9).position)
              for m in states if start <= m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 <= start + 1.2]
    assert len(errors) > 100
    assert_follows(errors, 0.03)  # rad, at up to 2 rad/s: cubic segments + one SYNC of timing
    wait_for(lambda: abs(position_of(states[-1]) - (here + 1.2)) < 1e-3, 3, 'the goal')
    feeder = bridge.trajectories.feeder(JOINT)
    assert feeder.stats.points >= round(1.2 / SEGMENT) and feeder.stats.motions == 1
    assert feeder.stats.min_free >= 1  # the buffer never filled up
    assert not [e for e in emcys if e.error_code in (0x8584, 0x8585)]  # no overflow, no underflow


def follow(client: ActionClient, target: float, duration: float):
    """A FollowJointTrajectory goal moving JOINT to ``target`` in ``duration`` s, accepted: its
    result future."""
    goal = FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=[JOINT],
                                                                 points=[point(duration, [target])]))
    sent = client.send_goal_async(goal)
    handle = wait_for(lambda: sent.result() if sent.done() else None, 10, 'goal answered')
    assert handle.accepted
    return handle.get_result_async()


def test_a_starved_stream_underflows_and_the_axis_is_held_until_resumed(ros, bridge) -> None:
    states, emcys, publisher = recorders(ros)
    watcher = ros.node('pvt_action')
    client = ActionClient(watcher, FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
    resume = watcher.create_client(AxisCommand, f'{NS}/resume')
    refusals: list[String] = []
    watcher.create_subscription(String, f'{NS}/command_errors', refusals.append, 10)
    assert client.wait_for_server(timeout_sec=10)
    here = position_of(states[-1])

    result_future = follow(client, here + 2.0, 2.0)
    time.sleep(0.6)
    drive = bridge.simulation.drive(1)
    drive.drop_rpdos(True)  # the stream starves: no more points reach the drive
    underflow = wait_for(lambda: next((e for e in emcys if e.error_code == 0x8585), None), 3, 'EMCY 0x8585')
    assert underflow.node_id == 1 and underflow.joint_name == JOINT
    assert 'underflow' in underflow.text.lower()
    result = wait_for(lambda: result_future.result() if result_future.done() else None, 5, 'result').result
    assert result.error_code == FollowJointTrajectory.Result.PATH_TOLERANCE_VIOLATED
    assert '0x8585' in result.error_string and 'held' in result.error_string
    drive.drop_rpdos(False)
    snapshot = bridge.master.axes[JOINT].snapshot()
    assert snapshot.halted and snapshot.state is State.OPERATION_ENABLED
    wait_for(lambda: drive.axis(0).controlword & 0x100, 2, 'HALT on the drive')
    held = position_of(states[-1])
    time.sleep(0.3)
    assert position_of(states[-1]) == pytest.approx(held, abs=1e-4)  # holding, not drifting
    assert here + 0.1 < held < here + 2.0

    # held: a trajectory on the topic is refused, saying so (it was accepted, then dropped unheard)
    publisher.publish(JointTrajectory(joint_names=[JOINT], points=[point(1.0, [held - 0.5])]))
    refusal = wait_for(lambda: next((m.data for m in refusals if 'held (HALT)' in m.data), None),
                       2 + BUSY_SLACK, 'the refusal on ~/command_errors')
    assert f'joint {JOINT} is held' in refusal and 'resume it first' in refusal, refusal
    assert position_of(states[-1]) == pytest.approx(held, abs=1e-4)

    # released: the next trajectory starts from where the drive stopped and reaches its goal
    before_resume = len(emcys)
    response = ros.call(resume, AxisCommand.Request(joints=[JOINT]))
    assert response.success, response.message
    second = follow(client, held - 0.5, 1.0)
    result = wait_for(lambda: second.result() if second.done() else None, 5 + BUSY_SLACK, 'second result').result
    assert result.error_code == FollowJointTrajectory.Result.SUCCESSFUL, result.error_string
    wait_for(lambda: abs(position_of(states[-1]) - (held - 0.5)) < 1e-3, 3, 'the second goal')
    assert not [e for e in emcys[before_resume:] if e.error_code in (0x8584, 0x8585)]


def test_pvt_replacement_splices_and_an_empty_trajectory_decelerates(ros, bridge) -> None:
    states, emcys, publisher = recorders(ros)
    axis = bridge.master.axes[JOINT]
    here = position_of(states[-1])
    publisher.publish(JointTrajectory(joint_names=[JOINT], points=[point(2.0, [here + 3.0])]))
    time.sleep(0.7)
    publisher.publish(JointTrajectory(joint_names=[JOINT], points=[point(1.0, [here + 0.5])]))
    time.sleep(1.4)
    wait_for(lambda: abs(position_of(states[-1]) - (here + 0.5)) < 1e-3, 3 + BUSY_SLACK, 'the replacement goal')
    velocities = [abs(dict(zip(m.name, m.velocity))[JOINT]) for m in states[-400:]]
    assert max(velocities) < 3.0  # the splice had no jump

    publisher.publish(JointTrajectory(joint_names=[JOINT], points=[point(2.0, [here - 2.5])]))
    wait_for(lambda: abs(axis.snapshot().velocity) > 1.0, 3, 'moving')
    publisher.publish(JointTrajectory(joint_names=[JOINT]))
    speeds = []
    for _ in range(20):
        speeds.append(abs(axis.snapshot().velocity))
        time.sleep(0.01)
    assert speeds[3] > 0.2, 'stopped at once instead of decelerating'
    wait_for(lambda: abs(axis.snapshot().velocity) < 1e-3, 5, 'standstill')
    assert bridge.trajectories.feeder(JOINT).ended  # the motion was closed with a time-0 point
    assert not [e for e in emcys if e.error_code in (0x8584, 0x8585)]
