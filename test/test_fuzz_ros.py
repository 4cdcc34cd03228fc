"""A hostile client against the demo node, through ROS only: NaN, +-inf, +-1e300, 0, a negative
number and a wrong type to every parameter, and the non-finite and huge values to every numeric
field of every topic, service request and goal the node takes. At the end the node is alive
and streaming /joint_states, and every bad value got a refusal that names it (the parameter, or
the field and value). Integer fields (node ids, indices, Duration's sec/nanosec) cannot carry
non-finite values over the wire: the message types refuse them at the client; an SDO value
beyond its data type is refused naming it. A trajectory point's effort is not read by the
bridge: a finite one is accepted, a non-finite one refused."""
from __future__ import annotations

import math
import time
from typing import Any

from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance
from drive_bridge_interfaces.msg import SdoValue
from drive_bridge_interfaces.srv import AxisCommand, SdoWrite, SetMode
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from test_motion_safety_ros import NS, Demo
from test_ros_parameters import ParameterClient
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from rostools import ActionClient, RosHarness, wait_for

NON_FINITE = [math.nan, math.inf, -math.inf]
HUGE = [1e300, -1e300]
PROBES = [0.0, -1.0]  # may be valid for a field: then accepted, else refused naming it
WRONG_TYPES = ['not a number', True, [1.0, 2.0]]


def text(value: float) -> str:
    return f'{value:.6g}' if math.isfinite(value) else str(value)


def test_every_parameter_and_numeric_field_refuses_bad_values_and_the_node_keeps_streaming(ros: RosHarness) -> None:
    demo = Demo(ros)
    try:
        _parameters(demo)
        _topics(demo)
        _services(demo)
        _goals(demo)
        count = len(demo.states)
        wait_for(lambda: len(demo.states) > count + 50, 5, '/joint_states still streaming at the end')
        assert all(a.available for a in demo.node.master.axes.values())
    finally:
        demo.close()


def _parameters(demo: Demo) -> None:
    client = ParameterClient(demo.ros, 'drive_bridge')
    names = sorted(demo.node._parameters)  # every parameter the node declared (record.* too)
    assert 'state_rate' in names and 'record.split_seconds' in names
    for name in names:
        if name == 'use_sim_time':
            continue
        before = demo.node._parameters[name].value
        for value in [*NON_FINITE, *HUGE, *PROBES, *WRONG_TYPES]:
            result = client.set(name, value)
            if result.successful:  # a valid value (0 where 0 means something, a text for a path): put it back
                assert (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)) \
                    or type(value) is type(before), (name, value)
                assert client.set(name, before).successful, (name, before)
                continue
            assert name in result.reason, (name, value, result.reason)
        assert demo.node._parameters[name].value == before, name


def _topics(demo: Demo) -> None:
    joints = list(demo.node.master.axes)
    commands = demo.client.create_publisher(Float64MultiArray, f'{NS}/commands', 10)
    joint_commands = demo.client.create_publisher(JointState, f'{NS}/joint_commands', 10)
    wait_for(lambda: commands.get_subscription_count() and joint_commands.get_subscription_count(), 5, 'subscribed')
    expected: list[tuple[str, str]] = []  # (topic, text) each refusal must carry
    for value in [*NON_FINITE, *HUGE]:
        here = [demo.position(j) for j in joints]
        commands.publish(Float64MultiArray(data=[value, *here[1:]]))
        expected.append(('~/commands', f'position {text(value)}'))
        for field in ('position', 'velocity', 'effort'):
            msg = JointState(name=['base_joint'], **{field: [value]})
            joint_commands.publish(msg)
            if math.isinf(value):
                expected.append(('joint_commands', f'{field}[0] (base_joint) is {value}'))
            elif field == 'position' and not math.isnan(value):
                expected.append(('joint_commands', f'position {text(value)}'))
        for field in ('positions', 'velocities', 'accelerations', 'effort'):
            point = JointTrajectoryPoint(positions=[demo.position('base_joint')], time_from_start=Duration(sec=1))
            if field != 'positions':
                point.velocities = [0.0]
            if field == 'accelerations':
                point.accelerations = [0.0]
            setattr(point, field, [value])
            demo.trajectories.publish(JointTrajectory(joint_names=['base_joint'], points=[point]))
            name = {'positions': 'position', 'velocities': 'velocity', 'accelerations': 'acceleration',
                    'effort': 'effort'}[field]
            if field == 'effort':  # not read: only a non-finite one is refused
                if not math.isfinite(value):
                    expected.append(('joint_trajectory', f'effort[0] is {value}'))
            elif math.isfinite(value):  # each refusal names its own field and value
                expected.append(('joint_trajectory', f'{name} {text(value)} of base_joint'))
            else:
                expected.append(('joint_trajectory', f'{name} of base_joint is {value}'))
        time.sleep(0.05)
    for topic, fragment in expected:
        wait_for(lambda: next((e for e in demo.errors if topic in e and fragment in e), None), 5,
                 f'a refusal on {topic} naming {fragment!r}')


def _services(demo: Demo) -> None:
    for value in [*NON_FINITE, *HUGE, -1.0]:
        for name in ('quick_stop', 'halt', 'resume', 'disable', 'enable', 'fault_reset', 'recover', 'home'):
            reply = demo.call(AxisCommand, name, joints=['lift_joint'], timeout=value)
            assert not reply.success and f'timeout {value!r} s refused' in reply.message, (name, value, reply)
        reply = demo.call(SetMode, 'set_mode', joints=['lift_joint'], mode='csp', timeout=value)
        assert not reply.success and f'timeout {value!r} s refused' in reply.message
    for value in NON_FINITE:
        reply = demo.call(SdoWrite, 'sdo_write', node_id=2, index=0x2000, subindex=0,
                          value=SdoValue(data_type=SdoValue.REAL32, float_value=value))
        assert not reply.success and f'value.float_value is {value}' in reply.message, reply.message
    for fields, fragment in [*((dict(data_type=SdoValue.REAL32, float_value=v), 'cannot encode as REAL32')
                               for v in HUGE),
                             *((dict(data_type=SdoValue.INTEGER16, int_value=v), f'{v} is outside INTEGER16')
                               for v in (2 ** 62, -2 ** 62)),
                             (dict(data_type=SdoValue.UNSIGNED16, uint_value=2 ** 63),
                              f'{2 ** 63} is outside UNSIGNED16'),
                             (dict(data_type=SdoValue.INTEGER8, int_value=-1000), '-1000 is outside INTEGER8')]:
        reply = demo.call(SdoWrite, 'sdo_write', node_id=2, index=0x2000, subindex=0, value=SdoValue(**fields))
        assert not reply.success and fragment in reply.message, (fields, reply.message)


def _goals(demo: Demo) -> None:
    client = ActionClient(demo.client, FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
    assert client.wait_for_server(timeout_sec=5)

    def result(goal: FollowJointTrajectory.Goal) -> Any:
        sent = client.send_goal_async(goal)
        handle = wait_for(lambda: sent.result() if sent.done() else None, 10, 'goal response')
        done = handle.get_result_async()
        return wait_for(lambda: done.result() if done.done() else None, 10, 'goal result').result

    here = demo.position('base_joint')
    for value in [*NON_FINITE, *HUGE]:
        point = JointTrajectoryPoint(positions=[value], time_from_start=Duration(sec=1))
        goal = FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=['base_joint'], points=[point]))
        answer = result(goal)
        assert answer.error_code == FollowJointTrajectory.Result.INVALID_GOAL and text(value) in answer.error_string
        for field, name in (('velocities', 'velocity'), ('accelerations', 'acceleration'), ('effort', 'effort')):
            if field == 'effort' and math.isfinite(value):
                continue  # not read: a finite effort is accepted
            point = JointTrajectoryPoint(positions=[here], velocities=[0.0], time_from_start=Duration(sec=1))
            if field == 'accelerations':
                point.accelerations = [0.0]
            setattr(point, field, [value])
            goal = FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=['base_joint'], points=[point]))
            answer = result(goal)
            fragment = (f'effort[0] is {value}' if field == 'effort' else f'{name} of base_joint is {value}'
                        if not math.isfinite(value) else f'{name} {text(value)} of base_joint')
            assert answer.error_code == FollowJointTrajectory.Result.INVALID_GOAL, (field, value, answer.error_string)
            assert fragment in answer.error_string, (field, value, answer.error_string)
        # tolerances follow control_msgs (> 0 checked, 0 / -1 not, an infinity "unbounded"): NaN means
        # nothing and is refused; an acceleration tolerance cannot be checked (no drive reports one)
        for kind in ('path', 'goal'):
            for field in ('position', 'velocity', 'acceleration'):
                if not math.isnan(value) and not (field == 'acceleration' and value > 0):
                    continue
                tolerance = JointTolerance(name='base_joint', **{field: value})
                goal = FollowJointTrajectory.Goal(trajectory=JointTrajectory(
                    joint_names=['base_joint'], points=[JointTrajectoryPoint(positions=[here],
                                                                             time_from_start=Duration(sec=1))]))
                setattr(goal, f'{kind}_tolerance', [tolerance])
                answer = result(goal)
                assert answer.error_code == FollowJointTrajectory.Result.INVALID_GOAL
                assert f'{kind}_tolerance: {field} tolerance' in answer.error_string
                assert 'base_joint' in answer.error_string
