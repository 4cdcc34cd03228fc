"""The SINAMICS S120 through ROS alone: a bus node with the shipped example (node 5 with two drive
objects, node 7 with one, simulated) runs in-process on a private rclpy context; the test talks to
it through topics, services and the FollowJointTrajectory action, records the CAN frames
(akdtools.Sniffer) and inspects the simulator to see what reached the drive. Timing bounds are
generous (noisy 2-core CI).

Figures: 2048 pulses x 2^11 = 4194304 increments per motor revolution, wrist gear 1, arm gear 10.
"""
from __future__ import annotations

import math
import struct
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance
from drive_bridge_interfaces.msg import AxisState
from drive_bridge_interfaces.srv import ParamRead, SetMode
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

from nodebench import NS, NodeBench, point
from rostools import ActionClient, RosHarness, wait_for
from timingtools import assert_follows

REPO = Path(__file__).resolve().parent.parent
EXAMPLE = REPO / 'config' / 's120_example.yaml'
MODULAR = REPO.parent / 'shared' / 'realdata' / 'eds' / 'SINAMICS_S120_V48__SINAMICS_S120.eds'
ARM, WRIST = 5, 7
JOINTS = ('shoulder_joint', 'elbow_joint', 'wrist_joint')
RAD_PER_INC = 2 * math.pi / (2048 << 11)
Result = FollowJointTrajectory.Result

pytestmark = pytest.mark.skipif(not MODULAR.exists(), reason='the Siemens EDS is in ../shared/realdata/eds')


def config_data(arm: dict[str, Any] | None = None, wrist: dict[str, Any] | None = None,
                reverse_arm: bool = False) -> dict[str, Any]:
    data = yaml.safe_load(EXAMPLE.read_text())  # NodeBench puts it on a local bus of its own
    data['defaults']['dcf'] = str(MODULAR)
    data['simulation']['nodes']['arm'].update(arm or {})
    data['simulation']['nodes']['wrist'].update(wrist or {})
    if reverse_arm:
        data['nodes']['arm']['axes'].reverse()
    return data


class Bench(NodeBench):
    """The S120 example's bus node (commands on ~/commands reach every joint in config order)."""

    def __init__(self, ros: RosHarness, interface: str = 'position', **config: Any) -> None:
        super().__init__(ros, config_data(**config), JOINTS,
                         [Parameter('command_interface', value=interface)])

@pytest.fixture
def bench(ros: RosHarness) -> Iterator[Bench]:
    bench = Bench(ros, wrist={'p8848': 3.0})  # 8 ms > 2 x 3 ms: no telegram-loss alarm on the wrist
    try:
        yield bench
    finally:
        bench.close()


def test_every_joint_publishes_and_set_mode_waits_for_0x6061(bench: Bench) -> None:
    msg = bench.states[-1]
    assert set(JOINTS) <= set(msg.name) and all(math.isfinite(p) for p in msg.position)
    # the second drive object of node 5 on its own COB-IDs: both of node 5's joints keep coming
    before = len(bench.states)
    time.sleep(0.3)
    assert sum(1 for m in bench.states[before:] if {'shoulder_joint', 'elbow_joint'} <= set(m.name)) > 5
    drive = bench.drive(ARM)
    done = bench.call(SetMode, 'set_mode', joints=['elbow_joint'], mode='pt')
    assert done.success, done.message
    assert drive.view(4).mode == 4
    wait_for(lambda: bench.axis_state('elbow_joint') is not None and bench.axis_state('elbow_joint').mode == 4, 3,
             'pt on ~/axis_states')
    mark = bench.sniffer.mark
    for mode in ('csp', 'ip', 'hm'):
        refused = bench.call(SetMode, 'set_mode', joints=['elbow_joint'], mode=mode)
        assert not refused.success and f'mode {mode} is not accepted by this drive family' in refused.message
    time.sleep(0.1)
    downloads = [struct.unpack_from('<H', f.data, 1)[0] for f in bench.sniffer.frames(0x600 + ARM, mark)
                 if f.data and f.data[0] & 0xE0 == 0x20]
    assert 0x6860 not in downloads and 0x6060 not in downloads
    assert drive.view(4).requested_mode == 4 and drive.view(4).mode == 4


def test_follow_joint_trajectory_on_a_pv_joint_through_the_bridges_loop(bench: Bench) -> None:
    assert bench.axis('enable', 'wrist_joint').success
    drive = bench.drive(WRIST)
    client = ActionClient(bench.watcher, FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
    assert client.wait_for_server(timeout_sec=10)
    start = bench.position('wrist_joint')
    goal = FollowJointTrajectory.Goal(
        trajectory=JointTrajectory(joint_names=['wrist_joint'],
                                   points=[point(1.5, [start + 1.0], [0.0], [0.0])]),  # quintic, 1 rad in 1.5 s
        path_tolerance=[JointTolerance(name='wrist_joint', position=0.05)],
        goal_tolerance=[JointTolerance(name='wrist_joint', position=0.005)])
    samples: list[tuple[float, float]] = []  # (desired, 0x6063 in rad) from the feedback
    sent = client.send_goal_async(goal, feedback_callback=lambda f: samples.append(
        (f.feedback.desired.positions[0], drive.view(2).position * RAD_PER_INC)))
    handle = wait_for(lambda: sent.result() if sent.done() else None, 10, 'goal response')
    assert handle.accepted
    future = handle.get_result_async()
    result = wait_for(lambda: future.result() if future.done() else None, 15, 'result').result
    assert (result.error_code, result.error_string) == (Result.SUCCESSFUL, '')
    assert len(samples) > 20
    assert_follows([abs(d - a) for d, a in samples], 0.06)  # 0x6063 off the desired path: tolerance 0.05 + one period
    wait_for(lambda: drive.view(2).setpoint == 0, 3, '0x60FF = 0 at rest')
    held = drive.view(2).position * RAD_PER_INC
    assert held == pytest.approx(start + 1.0, abs=5e-3)
    time.sleep(0.5)
    assert drive.view(2).position * RAD_PER_INC == pytest.approx(held, abs=1e-3)
    assert drive.view(2).mode == 3


def test_joint_trajectory_topic_then_a_stalled_command_stream_holds(bench: Bench) -> None:
    assert bench.axis('enable', 'wrist_joint').success
    drive = bench.drive(WRIST)
    start = bench.position('wrist_joint')
    wait_for(lambda: bench.trajectories.get_subscription_count() > 0, 5, 'the bridge subscribed')
    bench.trajectories.publish(JointTrajectory(joint_names=['wrist_joint'], points=[point(0.8, [start + 0.5])]))
    wait_for(lambda: abs(bench.position('wrist_joint') - (start + 0.5)) < 5e-3, 5, 'the trajectory done')
    assert not bench.errors
    # ~/commands (position, command_joints: all three): only the wrist is enabled -> refused whole
    here = bench.position('wrist_joint')
    bench.commands.publish(Float64MultiArray(data=[0.0, 0.0, here]))
    wait_for(lambda: bench.errors, 3, 'a refusal')
    assert 'shoulder_joint' in bench.errors[-1].data
    assert bench.axis('enable', 'shoulder_joint', 'elbow_joint').success
    shoulder, elbow = bench.position('shoulder_joint'), bench.position('elbow_joint')
    for k in range(30):
        bench.commands.publish(Float64MultiArray(data=[shoulder, elbow, here + 0.01 * k]))
        time.sleep(0.01)
    last = here + 0.29
    state = wait_for(lambda: bench.axis_state('wrist_joint') if bench.axis_state('wrist_joint').command_stale
                     else None, 3, 'stale on ~/axis_states')
    assert 'no command for 500 ms' in state.message and state.drive_state == AxisState.DRIVE_ENABLED
    wait_for(lambda: abs(drive.view(2).speed_rpm) < 0.5, 3, 'at rest')
    assert bench.position('wrist_joint') == pytest.approx(last, abs=0.01)
    time.sleep(0.5)
    assert bench.position('wrist_joint') == pytest.approx(last, abs=0.01)


def test_an_alarm_outside_the_can_range_is_a_warning_with_no_emcy(bench: Bench) -> None:
    assert bench.axis('enable', 'wrist_joint').success
    wait_for(lambda: bench.axis_state('wrist_joint') is not None
             and bench.axis_state('wrist_joint').drive_state == AxisState.DRIVE_ENABLED, 3, 'enabled')
    assert not bench.axis_state('wrist_joint').warning
    before = len(bench.emcys)
    bench.drive(WRIST).inject_alarm(7910, 2)
    wait_for(lambda: bench.axis_state('wrist_joint').warning, 3, 'the warning on ~/axis_states')
    time.sleep(0.3)
    assert not [e for e in bench.emcys[before:] if e.node_id == WRIST]
    assert bench.axis_state('wrist_joint').drive_state == AxisState.DRIVE_ENABLED
    bench.drive(WRIST).clear_cause(7910)
    wait_for(lambda: not bench.axis_state('wrist_joint').warning, 3, 'the warning gone')


def test_an_emcy_reaches_the_joint_of_its_drive_object_and_parameters_per_drive_object(ros: RosHarness) -> None:
    # p8743 = [4, 3] and the config lists slot 1 (elbow) first; max speed 3000 rpm in slot 0, 1500 in slot 1
    bench = Bench(ros, arm={'do_numbers': [4, 3], 'p8848': 3.0, 'max_speed': [3000.0, 1500.0]}, reverse_arm=True)
    try:
        assert bench.axis('enable', 'shoulder_joint', 'elbow_joint').success
        before = len(bench.emcys)
        bench.drive(ARM).inject_fault(7900, 3)  # DO 3 = p8743[1]: the elbow
        emcy = wait_for(lambda: next((e for e in bench.emcys[before:] if e.error_code == 0x1000), None), 3,
                        'the EMCY on ~/emcy')
        assert emcy.joint_name == 'elbow_joint' and emcy.severity == 'error'
        assert emcy.text.startswith('F07900 motor blocked (DO 3, axis slot 1')
        state = wait_for(lambda: bench.axis_state('elbow_joint') if bench.axis_state('elbow_joint').fault else None,
                         3, 'elbow fault on ~/axis_states')
        assert state.last_error_code == 0x1000 and state.last_error_text.startswith('F07900 motor blocked')
        assert bench.axis_state('shoulder_joint').drive_state == AxisState.DRIVE_ENABLED
        reset = bench.axis('fault_reset', 'elbow_joint', timeout=2.0)
        assert reset.success, reset.message
        # two parameter reads at once on the two DOs: each its own DO's value
        clients = [bench.watcher.create_client(ParamRead, f'{NS}/param_read') for _ in range(2)]
        for client in clients:
            assert client.wait_for_service(timeout_sec=10)
        for _ in range(5):
            futures = [client.call_async(ParamRead.Request(node_id=ARM, drive_object=do, parameter='p1082'))
                       for client, do in zip(clients, (3, 4))]
            answers = [wait_for(lambda f=f: f.result() if f.done() else None, 10, 'param_read') for f in futures]
            # max_speed goes by slot: slot 0 = DO 4 3000 rpm, slot 1 = DO 3 1500 rpm
            assert [(a.success, a.value, a.unit) for a in answers] == [(True, 1500.0, 'rpm'), (True, 3000.0, 'rpm')]
        # drive_object 0 with a joint: that joint's own drive object
        elbow = bench.call(ParamRead, 'param_read', joint='elbow_joint', parameter='p1082')
        shoulder = bench.call(ParamRead, 'param_read', joint='shoulder_joint', parameter='p1082')
        assert (elbow.success, elbow.value, shoulder.value) == (True, 1500.0, 3000.0), (elbow.message, shoulder.message)
    finally:
        bench.close()
