"""The bus node through ROS alone: topics, commands, services, diagnostics.

The node runs in-process on a private rclpy context, with simulated drives from the demo
configuration on a virtual bus of its own; the test talks to it only through ROS (and
inspects the simulators to check what reached the drives).
"""
from __future__ import annotations

import math
import time

import pytest
import yaml
from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from drive_bridge_interfaces.msg import AxisState, AxisStates, Emcy, SdoValue
from drive_bridge_interfaces.srv import AxisCommand, NmtCommand, SdoRead, SdoWrite, SetMode
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bridgetools import bridge_with_sim, node_snapshot
from bustools import demo_data
from drive_bridge.cia402.statemachine import State
from drive_bridge.ros.frames import stamp_from_seconds
from drive_bridge.ros.node import BusNode
from drive_bridge.streaming.trajectory import JointSample, Trajectory, TrajectoryPoint, joint_splines
from rostools import RosHarness, wait_for
from timingtools import BUSY_SLACK, CycleWatch, assert_follows, stamp_of, stamped_count

JOINTS = ['base_joint', 'shoulder_joint', 'elbow_joint', 'lift_joint']
SLOTS = {'base_joint': (2, 0), 'shoulder_joint': (3, 0), 'elbow_joint': (3, 1), 'lift_joint': (4, 0)}
NS = '/drive_bridge'


@pytest.fixture
def bridge(ros: RosHarness):
    with bridge_with_sim(ros, demo_data(), [Parameter('auto_enable', value=True)]) as node:
        node.master.wait_until_operational(10.0)
        wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10,
                 'auto_enable of every axis')
        yield node


class Recorder:
    """Collects messages of one topic."""

    def __init__(self, ros: RosHarness, msg_type, topic: str, depth: int = 1000) -> None:
        self.messages: list = []
        ros.node(f'rec_{topic.replace("/", "_").strip("_")}_{id(self) % 10000}').create_subscription(
            msg_type, topic, self.messages.append, depth)

    def wait(self, predicate, timeout: float, what: str):
        return wait_for(lambda: next((m for m in reversed(self.messages) if predicate(m)), None), timeout, what)


def sim_position_si(node: BusNode, joint: str) -> float:
    node_id, slot = SLOTS[joint]
    counts = node.simulation.drive(node_id).axis(slot).position
    return node.master.axes[joint].config.scaling.position_to_si(counts)


def call(ros: RosHarness, srv_type, name: str, **fields):
    client = ros.node(f'client_{name.strip("/").replace("/", "_")}_{time.monotonic_ns() % 100000}') \
        .create_client(srv_type, name)
    return ros.call(client, srv_type.Request(**fields), timeout=15.0)


def latest_positions(states: Recorder) -> dict[str, float]:
    msg = states.messages[-1]
    return dict(zip(msg.name, msg.position))


def test_joint_states_arrive_stamped_in_si_every_cycle(ros: RosHarness, bridge: BusNode) -> None:
    states = Recorder(ros, JointState, '/joint_states')
    wait_for(lambda: len(states.messages) > 60, 10, '60 joint states')
    watch, start = CycleWatch(bridge.master), time.time()
    time.sleep(0.5)
    cycles, end = watch.cycles, time.time()
    time.sleep(0.3)  # what was published in the window arrives
    published = stamped_count(states.messages, start, end)
    # one per SYNC: counted against the cycles the bridge ran (on a busy machine fewer than the
    # 125 of the grid), generous for messages a lagging subscriber misses
    assert cycles > 0 and published > 0.5 * cycles, (published, cycles)
    msg = states.messages[-1]
    assert list(msg.name) == JOINTS
    assert abs(stamp_of(msg) - time.time()) < BUSY_SLACK
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in states.messages[-50:]]
    assert all(b >= a for a, b in zip(stamps, stamps[1:]))
    for joint, position in latest_positions(states).items():
        assert position == pytest.approx(sim_position_si(bridge, joint), abs=1e-3)
    assert all(len(m.velocity) == len(m.effort) == 4 for m in states.messages[-5:])


def test_a_joint_trajectory_moves_the_axes_along_its_path(ros: RosHarness, bridge: BusNode) -> None:
    states = Recorder(ros, JointState, '/joint_states')
    wait_for(lambda: states.messages, 5, 'joint states')
    start_positions = latest_positions(states)
    goal = {'base_joint': start_positions['base_joint'] + 0.4,
            'lift_joint': start_positions['lift_joint'] + 0.05}
    msg = JointTrajectory(joint_names=list(goal))
    start = time.time() + 0.3
    msg.header.stamp = stamp_from_seconds(start)
    msg.points = [
        JointTrajectoryPoint(positions=[start_positions['base_joint'] + 0.2, start_positions['lift_joint'] + 0.02],
                             velocities=[0.3, 0.04], time_from_start=Duration(sec=0, nanosec=700_000_000)),
        JointTrajectoryPoint(positions=list(goal.values()), velocities=[0.0, 0.0],
                             time_from_start=Duration(sec=1, nanosec=400_000_000)),
    ]
    ros.node('traj_pub').create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10).publish(msg)
    lags = []
    for _ in range(40):
        lags.append(bridge.trajectories.lag)
        time.sleep(0.05)
    # the ideal path, from the same rules the bridge applies (cubic through the points)
    ideal = joint_splines(
        Trajectory(tuple(goal), tuple(TrajectoryPoint(p.time_from_start.sec + p.time_from_start.nanosec * 1e-9,
                                                      tuple(p.positions), tuple(p.velocities)) for p in msg.points)),
        start, {j: JointSample(start_positions[j], 0.0, 0.0) for j in goal})
    errors: dict[str, list[float]] = {j: [] for j in goal}
    checked = 0
    # a stalled cycle thread delays the stream (never jumps it): the path error allows for the
    # delay the stream accumulated
    shifts = [k * 0.002 for k in range(int(max(lags) / 0.002) + 2)]
    for m in states.messages:
        t = m.header.stamp.sec + m.header.stamp.nanosec * 1e-9
        if start <= t <= start + 1.4:
            for joint, position in zip(m.name, m.position):
                if joint in goal:
                    errors[joint].append(min(abs(position - ideal[joint].sample(t - shift).position)
                                             for shift in shifts))
            checked += 1
    assert checked > 100
    assert_follows(errors['base_joint'], 0.02)  # rad: drive lag and one SYNC of set-point latency
    assert_follows(errors['lift_joint'], 0.003)  # m
    wait_for(lambda: all(abs(latest_positions(states)[j] - p) < 1e-3 for j, p in goal.items()), 3, 'the goal')
    final = latest_positions(states)
    assert final['shoulder_joint'] == pytest.approx(start_positions['shoulder_joint'], abs=1e-3)


def test_direct_position_velocity_and_effort_commands(ros: RosHarness, bridge: BusNode) -> None:
    states = Recorder(ros, JointState, '/joint_states')
    wait_for(lambda: states.messages, 5, 'joint states')
    start = latest_positions(states)
    node = ros.node('commander')
    commands = node.create_publisher(Float64MultiArray, f'{NS}/commands', 10)
    targets = [start[j] + (0.02 if j != 'lift_joint' else 0.005) for j in JOINTS]
    for k in range(1, 26):  # a stream, as a forward_command_controller sends it: a ramp (a step the
        ramp = min(1.0, k / 10)  # limits do not allow in one cycle is refused)
        commands.publish(Float64MultiArray(data=[start[j] + ramp * (t - start[j]) for j, t in zip(JOINTS, targets)]))
        time.sleep(0.02)
    time.sleep(0.2)
    for joint, target in zip(JOINTS, targets):
        assert latest_positions(states)[joint] == pytest.approx(target, abs=1e-3)

    assert call(ros, SetMode, f'{NS}/set_mode', joints=['lift_joint'], mode='csv').success
    assert call(ros, SetMode, f'{NS}/set_mode', joints=['base_joint'], mode='cst').success
    joint_commands = node.create_publisher(JointState, f'{NS}/joint_commands', 10)
    before = latest_positions(states)['lift_joint']
    for k in range(1, 26):  # topic_based_ros2_control style: every field, the mode picks one (velocity
        ramp = min(1.0, k / 10)  # ramped within the lift's acceleration limit, from its drive's 0x60C5)
        joint_commands.publish(JointState(name=['lift_joint', 'base_joint'], position=[math.nan, math.nan],
                                          velocity=[0.05 * ramp, math.nan], effort=[math.nan, 0.3]))
        time.sleep(0.02)
    last = states.messages[-1]
    velocity = dict(zip(last.name, last.velocity))
    effort = dict(zip(last.name, last.effort))
    assert velocity['lift_joint'] == pytest.approx(0.05, rel=0.05)
    assert latest_positions(states)['lift_joint'] > before + 0.01
    assert effort['base_joint'] == pytest.approx(0.3, rel=0.05)
    # the command stream stopped: the dead-man holds the cyclic axes and says so
    time.sleep(0.8)
    snapshot = bridge.master.axes['lift_joint'].snapshot()
    assert snapshot.command_stale and 'holding position' in snapshot.message
    assert abs(dict(zip(states.messages[-1].name, states.messages[-1].velocity))['lift_joint']) < 0.005


def test_sdo_and_nmt_services_answer_typed_values_and_precise_errors(ros: RosHarness, bridge: BusNode) -> None:
    read = call(ros, SdoRead, f'{NS}/sdo_read', node_id=3, index=0x1018, subindex=2)
    assert read.success and read.value.data_type == SdoValue.UNSIGNED32 and read.value.uint_value == 0x402
    assert bytes(read.value.bytes_value) == b'\x02\x04\x00\x00'
    name = call(ros, SdoRead, f'{NS}/sdo_read', node_id=2, index=0x1008, subindex=0)
    assert name.success and name.value.string_value.startswith('drive_bridge simulated CiA 402 drive')
    written = call(ros, SdoWrite, f'{NS}/sdo_write', node_id=2, index=0x6065, subindex=0,
                   value=SdoValue(data_type=SdoValue.AUTO, uint_value=12345))
    assert written.success, written.message
    again = call(ros, SdoRead, f'{NS}/sdo_read', node_id=2, index=0x6065, subindex=0)
    assert again.value.uint_value == 12345
    negative = call(ros, SdoWrite, f'{NS}/sdo_write', node_id=2, index=0x607C, subindex=0,
                    value=SdoValue(data_type=SdoValue.INTEGER32, int_value=-5000))
    assert negative.success
    assert call(ros, SdoRead, f'{NS}/sdo_read', node_id=2, index=0x607C, subindex=0).value.int_value == -5000

    missing = call(ros, SdoRead, f'{NS}/sdo_read', node_id=2, index=0x2345, subindex=0,
                   data_type=SdoValue.UNSIGNED16)
    assert not missing.success and missing.abort_code == 0x06020000
    assert 'object does not exist' in missing.message
    too_big = call(ros, SdoWrite, f'{NS}/sdo_write', node_id=2, index=0x6065, subindex=0,
                   value=SdoValue(data_type=SdoValue.AUTO, uint_value=2 ** 40))
    assert not too_big.success and 'outside UNSIGNED32 range' in too_big.message
    unknown_node = call(ros, SdoRead, f'{NS}/sdo_read', node_id=50, index=0x1000, subindex=0)
    assert not unknown_node.success and 'not in the bus configuration' in unknown_node.message
    no_answer = call(ros, SdoRead, f'{NS}/sdo_read', node_id=50, index=0x1000, subindex=0,
                     data_type=SdoValue.UNSIGNED32)
    assert not no_answer.success and 'no valid SDO response' in no_answer.message

    bad = call(ros, NmtCommand, f'{NS}/nmt', command=7, node_id=2)
    assert not bad.success and 'unknown NMT command 7' in bad.message
    reset = call(ros, NmtCommand, f'{NS}/nmt', command=NmtCommand.Request.RESET_NODE, node_id=4)
    assert reset.success and reset.message == 'NMT reset node sent to node 4'
    wait_for(lambda: (node_snapshot(bridge, 'lift_drive').boot_attempts >= 2
                      and node_snapshot(bridge, 'lift_drive').available),
             5, 'node 4 configured again after its reset')


def test_axis_services_act_and_report_errors(ros: RosHarness, bridge: BusNode) -> None:
    axes = bridge.master.axes
    sim = bridge.simulation
    disabled = call(ros, AxisCommand, f'{NS}/disable', joints=['elbow_joint'])
    assert disabled.success and axes['elbow_joint'].state is State.SWITCHED_ON
    assert sim.drive(3).axis(1).state is State.SWITCHED_ON
    assert call(ros, AxisCommand, f'{NS}/enable', joints=[]).success  # all joints
    assert all(a.state is State.OPERATION_ENABLED for a in axes.values())
    assert call(ros, AxisCommand, f'{NS}/halt', joints=['base_joint']).success
    wait_for(lambda: sim.drive(2).axis(0).controlword & 0x100, 2, 'HALT bit on the bus')
    assert axes['base_joint'].state is State.OPERATION_ENABLED  # halt is not quick stop
    assert call(ros, AxisCommand, f'{NS}/resume', joints=['base_joint']).success
    wait_for(lambda: not sim.drive(2).axis(0).controlword & 0x100, 2, 'HALT bit cleared')
    stopped = call(ros, AxisCommand, f'{NS}/quick_stop', joints=['lift_joint'])
    assert stopped.success and sim.drive(4).axis(0).state in (State.SWITCH_ON_DISABLED, State.QUICK_STOP_ACTIVE)
    homed = call(ros, AxisCommand, f'{NS}/home', joints=['base_joint'])
    assert homed.success, homed.message
    assert axes['base_joint'].mode == 8  # back to csp after homing
    mode = call(ros, SetMode, f'{NS}/set_mode', joints=['shoulder_joint'], mode='pv')
    assert mode.success and sim.drive(3).axis(0).mode == 3
    bad_mode = call(ros, SetMode, f'{NS}/set_mode', joints=['shoulder_joint'], mode='warp')
    assert not bad_mode.success and "unknown mode 'warp'" in bad_mode.message
    unknown = call(ros, AxisCommand, f'{NS}/enable', joints=['wrist_joint'])
    assert not unknown.success and 'unknown joint(s) wrist_joint' in unknown.message
    assert list(unknown.failed) == ['wrist_joint']


def test_injected_fault_shows_as_emcy_axis_state_and_diagnostics_then_recovers(
        ros: RosHarness, bridge: BusNode) -> None:
    emcy = Recorder(ros, Emcy, f'{NS}/emcy')
    axis_states = Recorder(ros, AxisStates, f'{NS}/axis_states')
    diagnostics = Recorder(ros, DiagnosticArray, '/diagnostics')
    time.sleep(0.3)
    bridge.simulation.drive(2).inject_fault(0x2310)
    event = emcy.wait(lambda m: m.error_code == 0x2310, 3, 'EMCY 0x2310 on ~/emcy')
    assert (event.node_id, event.node_name, event.joint_name) == (2, 'base_drive', 'base_joint')
    assert event.text == 'continuous over-current' and 'generic' in event.register_text

    def base(msg: AxisStates) -> AxisState:
        return next(a for a in msg.axes if a.joint_name == 'base_joint')
    state = axis_states.wait(lambda m: base(m).fault, 3, 'fault in ~/axis_states')
    assert base(state).state == AxisState.STATE_FAULT and base(state).last_error_code == 0x2310
    assert base(state).last_error_text == 'continuous over-current'

    def axis_status(msg: DiagnosticArray):
        return next((s for s in msg.status if s.name == 'drive_bridge: axis base_joint'), None)
    report = diagnostics.wait(lambda m: axis_status(m) and axis_status(m).level == DiagnosticStatus.ERROR, 4,
                              'ERROR for base_joint on /diagnostics')
    assert 'continuous over-current' in axis_status(report).message
    node_status = next(s for s in report.status if s.name == 'drive_bridge: node base_drive')
    assert any(kv.key == 'last_emcy' and '0x2310' in kv.value for kv in node_status.values)

    refused = call(ros, AxisCommand, f'{NS}/enable', joints=['base_joint'])
    assert not refused.success and 'clear it with ~/fault_reset' in refused.message
    recovered = call(ros, AxisCommand, f'{NS}/recover', joints=['base_joint'])
    assert recovered.success, recovered.message
    assert bridge.simulation.drive(2).axis(0).state is State.OPERATION_ENABLED
    axis_states.wait(lambda m: not base(m).fault and base(m).state == AxisState.STATE_OPERATION_ENABLED, 3,
                     'recovered state on ~/axis_states')


def _point(t: float, positions, velocities=()):
    return JointTrajectoryPoint(positions=list(positions), velocities=list(velocities),
                                time_from_start=Duration(sec=int(t), nanosec=int((t % 1) * 1e9)))


@pytest.mark.parametrize('joints, points, reason', [
    (['base_joint', 'wrist_joint'], [_point(1, [0.1, 0.1])], 'unknown joint(s) wrist_joint'),
    (['base_joint'], [_point(1, [0.1]), _point(0.5, [0.2])], 'point 1: time_from_start 0.5 s is not after'),
    (['base_joint'], [_point(1, [math.nan])], 'point 0: position of base_joint is nan'),
    (['base_joint', 'lift_joint'], [_point(1, [0.1, 0.9])], 'position 0.9 of lift_joint is above its limit 0.5'),
    (['base_joint', 'lift_joint'], [_point(1, [0.1])], 'point 0: 1 positions for 2 joints'),
    (['base_joint'], [_point(1, [0.1], [5.0])], 'velocity 5 of base_joint exceeds its limit 2'),
])
def test_malformed_trajectories_are_refused_whole(ros: RosHarness, bridge: BusNode, joints, points,
                                                 reason: str) -> None:
    errors = Recorder(ros, String, f'{NS}/command_errors')
    states = Recorder(ros, JointState, '/joint_states')
    wait_for(lambda: states.messages, 5, 'joint states')
    before = latest_positions(states)
    publisher = ros.node('bad_traj').create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    time.sleep(0.3)  # discovery
    publisher.publish(JointTrajectory(joint_names=joints, points=points))
    error = errors.wait(lambda m: True, 3, 'a message on ~/command_errors')
    assert error.data.startswith('~/joint_trajectory: refused: ') and reason in error.data, error.data
    time.sleep(0.3)
    after = latest_positions(states)
    assert all(after[j] == pytest.approx(before[j], abs=1e-4) for j in JOINTS)
    assert not bridge.trajectories.active()


def test_bus_events_reach_the_log_at_their_severity(ros: RosHarness, bridge: BusNode) -> None:
    from rcl_interfaces.msg import Log
    logs: list[Log] = []
    ros.node('log_watch').create_subscription(Log, '/rosout', logs.append, 100)
    time.sleep(0.3)
    bridge.simulation.drive(4).stop_heartbeat()
    lost = wait_for(lambda: next((m for m in logs if 'heartbeat lost' in m.msg), None), 3, 'heartbeat lost log')
    assert lost.level == Log.ERROR and lost.name == 'drive_bridge'
    bridge.simulation.drive(4).start_heartbeat()
    back = wait_for(lambda: next((m for m in logs if 'heartbeat back' in m.msg), None), 3, 'heartbeat back log')
    assert back.level == Log.WARN
    bridge.simulation.drive(2).inject_fault(0x2310)
    fault = wait_for(lambda: next((m for m in logs if '0x2310' in m.msg), None), 3, 'EMCY log')
    assert fault.level == Log.ERROR and 'continuous over-current' in fault.msg


@pytest.mark.parametrize('topic, msg, reason', [
    ('commands', Float64MultiArray(data=[0.1, 0.2]), '2 value(s) for 4 joint(s)'),
    ('commands', Float64MultiArray(data=[0.0, 0.0, math.nan, 0.0]), 'position nan is not a finite number'),
    ('commands', Float64MultiArray(data=[0.0, 0.0, 0.0, 9.0]), 'position 9 is above the limit 0.5'),
    ('joint_commands', JointState(name=['nope'], position=[0.1]), 'unknown joint(s) nope'),
    ('joint_commands', JointState(name=['base_joint', 'lift_joint'], position=[0.1]),
     '1 position value(s) for 2 name(s)'),
])
def test_bad_command_messages_are_refused_with_the_reason(ros: RosHarness, bridge: BusNode, topic, msg,
                                                         reason: str) -> None:
    errors = Recorder(ros, String, f'{NS}/command_errors')
    publisher = ros.node(f'bad_{topic}').create_publisher(type(msg), f'{NS}/{topic}', 10)
    wait_for(lambda: publisher.get_subscription_count(), 5, 'the bridge subscribed')
    before = {j: a.snapshot().position for j, a in bridge.master.axes.items()}
    publisher.publish(msg)
    error = errors.wait(lambda m: True, 3, 'a refusal')
    assert error.data.startswith(f'~/{topic}: refused: ') and reason in error.data, error.data
    time.sleep(0.2)
    assert all(abs(a.snapshot().position - before[j]) < 1e-4 for j, a in bridge.master.axes.items())


def test_command_joints_takes_a_string_list(ros: RosHarness) -> None:
    """The parameter defaults to every joint (empty list); a stack gives the order it sends."""
    text = yaml.safe_dump(demo_data(), sort_keys=False)
    node = BusNode(context=ros.context, node_name='drive_bridge_cj', parameter_overrides=[
        Parameter('config_yaml', value=text), Parameter('command_joints', value=['lift_joint', 'base_joint'])])
    try:
        assert node.params.command_joints == ('lift_joint', 'base_joint')
    finally:
        node.close()
