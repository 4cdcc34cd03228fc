"""Issue 20's findings through ROS, against the demo configuration with simulated drives (as
test_ros_node does): the motion between points is checked (and a set-point beyond a limit never
reaches the drive: its received RPDOs are recorded), past stamps start from the current state,
service timeouts are bounded and an unconfirmed mode is undone, no parameter or message value
ends the node, safety objects are closed, a drive that runs on by itself is stopped, and a fault
refusal names the fault and the way out. Bounds are generous (a busy 2-core machine)."""
from __future__ import annotations

import math
import struct
import time
from typing import Any

import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from drive_bridge_interfaces.msg import AxisStates, SdoValue
from drive_bridge_interfaces.srv import AxisCommand, SdoRead, SdoWrite, SetMode
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from test_ros_parameters import ParameterClient
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bridgetools import LocalSniffer, bridge_with_sim
from bustools import demo_data
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import State
from drive_bridge.joint import Setpoint
from drive_bridge.ros import parameters as node_parameters
from drive_bridge.ros.callback_guard import failures_of
from drive_bridge.ros.frames import stamp_from_seconds
from rostools import ActionClient, RosHarness, wait_for

NS = '/drive_bridge'
RPDO2_BASE = 0x302  # node 2: 0x607A target position, 0x60FF target velocity (int32 each)
PERIOD = 0.004


class Demo:
    def __init__(self, ros: RosHarness, **extra: Any) -> None:
        data = demo_data()
        data.update(extra)
        self.ros = ros
        self._bridge = bridge_with_sim(ros, data, [Parameter('auto_enable', value=True)])
        self.node = self._bridge.__enter__()
        self.sniffer = LocalSniffer(self.node.master.config.bus.channel)
        self.node.master.wait_until_operational(10.0)
        wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in self.node.master.axes.values()), 10,
                 'auto_enable of every axis')
        self.client = ros.node(f'safety_client_{time.monotonic_ns() % 1000000}')
        self.errors: list[str] = []
        self.states: list[JointState] = []
        self.axis_states: list[AxisStates] = []
        self.diagnostics: list[DiagnosticArray] = []
        self.client.create_subscription(String, f'{NS}/command_errors', lambda m: self.errors.append(m.data), 100)
        self.client.create_subscription(JointState, '/joint_states', self.states.append, 100)
        self.client.create_subscription(AxisStates, f'{NS}/axis_states', self.axis_states.append, 100)
        self.client.create_subscription(DiagnosticArray, '/diagnostics', self.diagnostics.append, 10)
        self.trajectories = self.client.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
        wait_for(lambda: self.states, 5, 'joint states')

    def call(self, srv_type: Any, name: str, **fields: Any) -> Any:
        client = self.client.create_client(srv_type, f'{NS}/{name}')
        return self.ros.call(client, srv_type.Request(**fields), timeout=15.0)

    def position(self, joint: str) -> float:
        msg = next(m for m in reversed(self.states) if joint in m.name)
        return dict(zip(msg.name, msg.position))[joint]

    def send(self, points: list[tuple[float, float, float | None]], joint: str = 'base_joint',
             stamp: float | None = None) -> None:
        msg = JointTrajectory(joint_names=[joint])
        if stamp is not None:
            msg.header.stamp = stamp_from_seconds(stamp)
        for t, p, v in points:
            msg.points.append(JointTrajectoryPoint(positions=[p], velocities=[] if v is None else [v],
                                                   time_from_start=Duration(sec=int(t), nanosec=round(t % 1 * 1e9))))
        self.trajectories.publish(msg)

    def error(self, text: str, timeout: float = 3.0) -> str:
        return wait_for(lambda: next((e for e in self.errors if text in e), None), timeout, f'an error with {text!r}')

    def base_targets(self, after: int = 0) -> list[float]:
        return [t for t, _stamp in self.base_frames(after)]

    def base_frames(self, after: int = 0) -> list[tuple[float, float]]:
        """(target position SI, send time) of every RPDO2 the base drive received."""
        scaling = self.node.master.axes['base_joint'].config.scaling
        return [(scaling.position_to_si(struct.unpack('<ii', f.data)[0]), f.stamp)
                for f in self.sniffer.frames(RPDO2_BASE, after)]

    def close(self) -> None:
        self._bridge.__exit__(None, None, None)
        self.sniffer.close()


@pytest.fixture
def demo(ros: RosHarness) -> Any:
    bench = Demo(ros)
    yield bench
    bench.close()


MAX_VELOCITY = 2.0  # base_joint's limits.max_velocity, rad/s
# s a cycle thread may be held between its SYNC and the set-points it sends (a busy machine): a
# frame then carries the motion up to its grid time, that much after its send time
PREEMPTION = 0.02
WINDOW = 0.2  # s: the speed over the motion, measured over windows at least this long


def beyond_velocity(frames: list[tuple[float, float]], velocity: float = MAX_VELOCITY) -> list[str]:
    """What in the set-points the drive received (target, send time) moved faster than ``velocity``:
    a jump between two frames (more than the motion of the time between them, one cycle and a
    held cycle thread allowed: a jump carries far more), and a window of WINDOW s or more over
    which the set-points moved faster on average (5 % allowed, the edges' cycles and a held
    thread too: catches a motion that was not slowed to the limit, which the pairs alone cannot
    tell from send jitter)."""
    found = []
    for (a, ta), (b, tb) in zip(frames, frames[1:]):
        if abs(b - a) > velocity * (max(tb - ta, PERIOD) + PERIOD + PREEMPTION) + 1e-4:
            found.append(f'jump {b - a:+.4f} in {1000 * (tb - ta):.1f} ms')
    start = 0
    for end in range(len(frames)):
        while frames[end][1] - frames[start][1] > WINDOW and start < end:
            start += 1
        (a, ta), (b, tb) = frames[start - 1 if start else 0], frames[end]
        if tb - ta >= WINDOW and abs(b - a) > 1.05 * velocity * (tb - ta + 2 * PERIOD + PREEMPTION) + 1e-4:
            found.append(f'{(b - a) / (tb - ta):+.3f} rad/s over {1000 * (tb - ta):.0f} ms')
    return found


def test_1_the_step_and_the_overshoot_are_refused_and_no_set_point_beyond_a_limit_reaches_the_drive(demo: Demo) -> None:
    here = demo.position('base_joint')
    mark = demo.sniffer.mark
    demo.send([(0.001, here, None), (0.002, here + 2.5, None)])
    text = demo.error('segment point 0 -> point 1: base_joint needs velocity')
    assert 'beyond its limit 2' in text and 'scale_to_limits' in text
    demo.send([(3.0, 3.0, 0.0), (5.0, 3.0, -2.0), (9.0, 0.0, 0.0)])
    text = demo.error('base_joint reaches position 3.59')
    assert 'segment point 0 -> point 1' in text and 'position limit 3.1' in text
    # past the validator (a bug in a set-point source): the cycle check holds the axis, says why
    # on ~/command_errors, ~/axis_states and /diagnostics, and the jump never reaches the drive
    demo.node.master.inject_setpoint('base_joint', Setpoint(position=here + 1.0))  # the test hook
    text = demo.error('cycle check: refused')
    assert 'base_joint' in text and 'beyond limits.max_velocity 2' in text
    wait_for(lambda: any(a.joint_name == 'base_joint' and a.halted and 'set-point refused' in a.message
                         for m in demo.axis_states for a in m.axes), 3, 'the refusal on ~/axis_states')
    wait_for(lambda: any(s.name == 'drive_bridge: axis base_joint' and s.level == DiagnosticStatus.ERROR
                         and 'set-point refused' in s.message for m in demo.diagnostics for s in m.status), 4,
             'the refusal on /diagnostics')
    targets = demo.base_targets(mark)
    assert targets and max(abs(t - here) for t in targets) < 0.01, 'a refused set-point reached the drive'
    assert not beyond_velocity(demo.base_frames(mark))
    refused = demo.call(AxisCommand, 'resume', joints=['base_joint'])
    assert refused.success, refused.message


def test_1_with_scale_to_limits_the_step_is_stretched_and_every_step_stays_within_the_limits(ros: RosHarness) -> None:
    demo = Demo(ros, trajectory={'scale_to_limits': True})
    try:
        here = demo.position('base_joint')
        mark = demo.sniffer.mark
        demo.send([(0.001, here, None), (0.002, here + 0.5, None)])
        wait_for(lambda: abs(demo.position('base_joint') - (here + 0.5)) < 2e-3, 5, 'the stretched motion done')
        targets = demo.base_targets(mark)
        assert max(targets) <= here + 0.5 + 1e-4
        assert not beyond_velocity(demo.base_frames(mark))  # never faster than max_velocity
        assert not [e for e in demo.errors if 'base_joint' in e]
    finally:
        demo.close()


def test_2_a_past_stamp_starts_from_the_current_state_without_a_jump(demo: Demo) -> None:
    here = demo.position('base_joint')
    mark = demo.sniffer.mark
    now = time.time()
    demo.send([(3.0, here + 1.0, None), (6.0, here + 1.67, None)], stamp=now - 5.0)
    wait_for(lambda: abs(demo.position('base_joint') - (here + 1.67)) < 2e-3, 5, 'the end of the trajectory')
    targets = demo.base_targets(mark)
    assert abs(targets[0] - here) < 0.02, 'the first set-point jumped'
    assert not beyond_velocity(demo.base_frames(mark))
    demo.send([(1.0, here, None)], stamp=now - 5.0)  # ends in the past: still refused
    demo.error('in the past')


def test_3_timeouts_are_bounded_and_an_unconfirmed_mode_is_undone(demo: Demo) -> None:
    refused = demo.call(SetMode, 'set_mode', joints=['base_joint'], mode='-100', timeout=1e6)
    assert not refused.success and 'timeout 1000000.0 s refused' in refused.message and '0..30' in refused.message
    for name in ('quick_stop', 'halt', 'disable', 'enable'):
        bad = demo.call(AxisCommand, name, joints=['base_joint'], timeout=math.inf)
        assert not bad.success and 'timeout inf s refused' in bad.message
    failed = demo.call(SetMode, 'set_mode', joints=['base_joint'], mode='-100', timeout=0.3)
    assert not failed.success and 'the previous mode csp is restored' in failed.message, failed.message
    assert demo.node.master.axes['base_joint'].mode == 8  # csp requested again, and confirmed
    assert demo.node.simulation.drive(2).axis(0).mode == 8
    # a drive that takes neither the new mode nor the previous one back (it runs pv whatever is
    # asked): the axis is held (HALT) and its state says why
    drive_axis = demo.node.simulation.drive(2).axis(0)
    switch = drive_axis.switch_mode
    drive_axis.switch_mode = lambda _code: switch(Mode.PROFILE_VELOCITY)
    failed = demo.call(SetMode, 'set_mode', joints=['base_joint'], mode='csv', timeout=0.3)
    assert not failed.success, failed.message
    assert 'the previous mode csp was not confirmed either: axis held (HALT)' in failed.message, failed.message
    wait_for(lambda: any(a.joint_name == 'base_joint' and a.halted and 'not confirmed' in a.message
                         for m in demo.axis_states for a in m.axes), 3, 'the held axis and its cause on ~/axis_states')


def test_4_no_parameter_value_ends_the_node_and_inf_commands_are_refused(demo: Demo) -> None:
    params = ParameterClient(demo.ros, 'drive_bridge')
    for name, value in (('state_rate', 1e-300), ('diagnostics_period', math.nan), ('diagnostics_period', math.inf),
                        ('diagnostics_period', 1e12), ('publish_rate', 1e-300), ('publish_rate', math.nan)):
        result = params.set(name, value)
        assert not result.successful and f'parameter {name} must be' in result.reason, (name, value, result)
    demo.client.create_publisher(JointState, f'{NS}/joint_commands', 10).publish(
        JointState(name=['base_joint'], position=[math.inf]))
    demo.error('position[0] (base_joint) is inf')
    count = len(demo.states)
    wait_for(lambda: len(demo.states) > count + 20, 3, 'joint states still streaming')


def test_4_an_unexpected_error_in_a_callback_is_a_logged_refusal_and_the_node_keeps_running(
        demo: Demo, monkeypatch: pytest.MonkeyPatch) -> None:
    """The callback guard: a bug (here an injected RuntimeError) in a service, a subscription, the
    parameter callback and the action's execute is answered as a refusal naming it; the node
    spins on, streams, and serves the same callbacks once the bug is gone."""
    def bug(*_args: Any, **_kwargs: Any) -> Any:
        raise RuntimeError('injected bug')
    master = demo.node.master
    with monkeypatch.context() as patch:
        patch.setattr(master, 'sdo_read', bug)  # under ~/sdo_read
        reply = demo.call(SdoRead, 'sdo_read', node_id=2, index=0x6041, subindex=0)
        assert not reply.success and 'unexpected error' in reply.message and 'injected bug' in reply.message
        patch.setattr(master.commands, 'submit', bug)  # under ~/commands
        demo.client.create_publisher(Float64MultiArray, f'{NS}/commands', 10).publish(
            Float64MultiArray(data=[demo.position(j) for j in master.axes]))
        demo.error("~/commands: refused: unexpected error RuntimeError('injected bug')")
        patch.setattr(node_parameters, 'validate', bug)  # under the parameter callback
        result = ParameterClient(demo.ros, 'drive_bridge').set('publish_rate', 0.0)
        assert not result.successful and 'publish_rate' in result.reason and 'injected bug' in result.reason
        patch.setattr(master.executor, 'submit_async', bug)  # under the action's execute
        action = ActionClient(demo.client, FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
        assert action.wait_for_server(timeout_sec=5)
        here = demo.position('base_joint')
        goal = FollowJointTrajectory.Goal(trajectory=JointTrajectory(joint_names=['base_joint'], points=[
            JointTrajectoryPoint(positions=[here], time_from_start=Duration(sec=1))]))
        sent = action.send_goal_async(goal)
        handle = wait_for(lambda: sent.result() if sent.done() else None, 10, 'goal response')
        done = handle.get_result_async()
        answer = wait_for(lambda: done.result() if done.done() else None, 10, 'goal result').result
        assert answer.error_code != FollowJointTrajectory.Result.SUCCESSFUL and 'injected bug' in answer.error_string
    assert failures_of(demo.node).count >= 4
    count = len(demo.states)
    wait_for(lambda: len(demo.states) > count + 20, 3, 'joint states still streaming')
    assert demo.call(SdoRead, 'sdo_read', node_id=2, index=0x6041, subindex=0).success  # served again
    assert ParameterClient(demo.ros, 'drive_bridge').set('publish_rate', 0.0).successful


def test_5_safety_objects_are_closed_by_default(demo: Demo) -> None:
    for index in (0x6007, 0x1017):
        refused = demo.call(SdoWrite, 'sdo_write', node_id=2, index=index, subindex=0,
                            value=SdoValue(data_type=SdoValue.INTEGER16 if index == 0x6007 else SdoValue.UNSIGNED16))
        assert not refused.success and 'access.' in refused.message
    refused = demo.call(SdoWrite, 'sdo_write', node_id=2, index=0x6007, subindex=0,
                        value=SdoValue(data_type=SdoValue.INTEGER16, int_value=0))
    assert 'access.safety_objects' in refused.message and 'abort connection option code' in refused.message


def test_7_a_fault_refusal_names_the_emcy_and_the_way_out(demo: Demo) -> None:
    demo.node.simulation.drive(2).inject_fault(0x2310)
    wait_for(lambda: demo.node.master.axes['base_joint'].snapshot().fault, 3, 'the fault')
    demo.send([(1.0, demo.position('base_joint') + 0.1, None)])
    text = demo.error('base_joint is in fault')
    assert 'last EMCY 0x2310 continuous over-current at' in text and '~/fault_reset' in text and '~/recover' in text
    assert '0x603F error code 0x2310' in text
    refused = demo.call(AxisCommand, 'enable', joints=['base_joint'])
    assert not refused.success and '0x2310' in refused.message and '~/recover' in refused.message
    assert demo.call(AxisCommand, 'recover', joints=['base_joint']).success


def test_6_a_drive_that_runs_on_is_stopped_when_its_guarding_is_lost_while_it_still_sends(ros: RosHarness) -> None:
    from test_opendrive_ros import JOINT as SPINDLE, NODE, RPDO1, RUN, Bench as OpenBench
    bench = OpenBench(ros, guard_time_ms=50, life_time_factor=3, command_timeout_ms=2000)
    try:
        drive = bench.drive
        assert bench.axis('enable').success
        for _ in range(10):
            bench.publisher.publish(Float64MultiArray(data=[50.0]))  # 477.5 rpm
            time.sleep(0.02)
        wait_for(lambda: abs(drive.speed_rpm - 477.5) < 5, 3, 'the motor at 477.5 rpm')
        mark = bench.sniffer.mark
        drive.stop_guarding_replies(True)  # the drive runs on, its TPDOs still arrive
        wait_for(lambda: next((m for m in bench.logs if 'keeps its last references without a master' in m.msg), None),
                 3, 'the run-on stop reported')
        wait_for(lambda: abs(drive.speed_rpm) < 1, 15, 'the motor at rest (its own ramp, RUN low)')
        wait_for(lambda: next((m for m in bench.logs if 'at rest: stop no longer sent' in m.msg), None), 3,
                 'at rest reported')
        sent = bench.rpdos(mark)
        stops = [f for f in sent if f == (0, 0, 0)]
        assert stops and all(word & RUN == 0 for word, _s, _t in sent[sent.index(stops[0]):])
        sdo = [f for f in bench.sniffer.frames(0x600 + NODE, mark) if f.data[1:3] == bytes([0x1F, 0x20])]
        assert sdo, 'RUN low was not written by SDO too'
        assert len([m for m in bench.logs if 'keeps its last references without a master' in m.msg]) == 1
        assert not drive.running
        assert RPDO1 == 0x200 + NODE and SPINDLE
    finally:
        bench.close()
