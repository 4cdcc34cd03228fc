"""Offline replay through the bridge's decoders reproduces what the bridge published live.

The bridge runs the demo bus against its simulated drives while a trajectory moves two
joints, a fault is injected and a heartbeat stops; the bridge's recorder writes every frame
of its tap to a rosbag2 bag (with the bus config), and a subscriber captures /joint_states,
~/axis_states and ~/emcy. ``drive-bridge replay --decode``
then turns the raw-frame bag into decoded topics, compared per stamp with the live ones.
"""
from __future__ import annotations

import bisect
import time
from pathlib import Path

import can
import pytest
import yaml
from drive_bridge_interfaces.msg import AxisStates, Emcy
from rclpy.parameter import Parameter
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState
from test_streaming_ros import point
from trajectory_msgs.msg import JointTrajectory

from bridgetools import start_bridge, stop_bridge
from bustools import demo_data
from drive_bridge.bag.typestore import typestore
from drive_bridge.cia402.statemachine import State
from drive_bridge.cli.main import main
from rostools import RosHarness, wait_for

NS = '/drive_bridge'
STAMP_TOLERANCE_NS = 2_000  # float seconds -> ns rounding of frame and message stamps
POSITION_TOLERANCE = 1e-9  # rad / m: the same numbers through the same scaling
PUBLISH_LAG = 0.2  # s an axis state may take from the bus process to its (publication-stamped) message
CYCLE = 0.004


def ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def read_topics(bag: Path) -> dict[str, list]:
    out: dict[str, list] = {}
    with AnyReader([bag], default_typestore=typestore()) as reader:
        for connection, stamp, raw in reader.messages():
            out.setdefault(connection.topic, []).append((stamp, reader.deserialize(raw, connection.msgtype)))
    return out


@pytest.fixture(scope='module')
def recorded(tmp_path_factory):
    """(raw-frame bag recorded by the bridge, live joint states, live axis states, live EMCYs)
    of a trajectory run with a fault and a heartbeat loss."""
    ros = RosHarness()
    bags = tmp_path_factory.mktemp('decode')
    live_joints: list[JointState] = []
    live_axes: list[AxisStates] = []
    live_emcy: list[Emcy] = []
    node = None
    try:
        node = start_bridge(ros, demo_data(), [
            Parameter('auto_enable', value=True),
            Parameter('record.path', value=str(bags)), Parameter('record.start', value=True)])
        node.master.wait_until_operational(10.0)
        wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10, 'enabled')
        listener = ros.node('live_listener')
        listener.create_subscription(JointState, '/joint_states', live_joints.append, 1000)
        listener.create_subscription(AxisStates, f'{NS}/axis_states', live_axes.append, 1000)
        listener.create_subscription(Emcy, f'{NS}/emcy', live_emcy.append, 100)
        publisher = listener.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
        wait_for(lambda: live_joints, 5, 'live joint states')
        start = {j: node.master.axes[j].snapshot().position for j in ('base_joint', 'elbow_joint')}
        publisher.publish(JointTrajectory(joint_names=list(start), points=[
            point(0.4, [start['base_joint'] + 0.15, start['elbow_joint'] - 0.1]),
            point(0.8, [start['base_joint'] + 0.2, start['elbow_joint'] - 0.15])]))
        time.sleep(1.3)
        lift = node.simulation.drive('lift_drive')
        lift.inject_fault(0x2310)  # EMCY + fault state
        time.sleep(0.3)
        lift.stop_heartbeat()  # heartbeat lost (limit 300 ms), then back
        time.sleep(0.6)
        lift.start_heartbeat()
        time.sleep(0.4)
    finally:
        if node is not None:
            stop_bridge(node)
        ros.shutdown()
    assert live_emcy, 'the injected fault sent no EMCY'
    bag, = bags.iterdir()
    return bag, list(live_joints), list(live_axes), list(live_emcy)


@pytest.fixture(scope='module')
def decoded(recorded, tmp_path_factory):
    bag = recorded[0]
    out = tmp_path_factory.mktemp('decoded') / 'out'
    started = time.perf_counter()
    assert main(['replay', str(bag), '--decode', '-o', str(out), '--quiet']) == 0
    return out, time.perf_counter() - started


def test_decoded_joint_states_match_the_live_ones_per_stamp(recorded, decoded) -> None:
    live = recorded[1]
    topics = read_topics(decoded[0])
    offline = [msg for _, msg in topics['/joint_states']]
    stamps = [ns(m.header.stamp) for m in offline]
    first, last = stamps[0], stamps[-1]
    in_range = [m for m in live if first <= ns(m.header.stamp) <= last]
    assert len(in_range) > 200, 'the run published too few joint states to compare'
    matched = mismatched = names_differ = 0
    moved = 0.0
    for msg in in_range:
        stamp = ns(msg.header.stamp)
        i = bisect.bisect_left(stamps, stamp - STAMP_TOLERANCE_NS)
        if i == len(stamps) or abs(stamps[i] - stamp) > STAMP_TOLERANCE_NS:
            continue  # the live cycle read while a cycle's TPDOs were still arriving
        matched += 1
        other = offline[i]
        if list(other.name) != list(msg.name):
            # lift_joint is left out while its heartbeat is lost: the live supervision and the
            # offline decode (from the frames' stamps) may decide that a cycle or two apart
            assert set(other.name) ^ set(msg.name) == {'lift_joint'}, (list(other.name), list(msg.name))
            names_differ += 1
            continue
        same = all(abs(a - b) <= POSITION_TOLERANCE for a, b in zip(other.position, msg.position)) and \
            all(abs(a - b) <= POSITION_TOLERANCE for a, b in zip(other.velocity, msg.velocity))
        mismatched += not same
        moved = max(moved, abs(msg.velocity[0]))
    print(f'joint states: {matched} of {len(in_range)} live stamps decoded, {mismatched} differ, '
          f'{names_differ} with lift_joint in one and not the other')
    assert names_differ <= 0.05 * matched, f'{names_differ} of {matched} stamps differ in their joints'
    assert moved > 0.1, 'the trajectory did not move base_joint'
    # a live cycle may read a joint's position while its next TPDO is being stored; and the drives,
    # simulated in this test's own busy process on the local bus, answer some SYNCs late: the
    # cycle then sends the state it has at the next SYNC, which the offline decode does not rebuild
    # (77-88 % of the stamps decoded after the bus process split, by load)
    assert matched >= 0.7 * len(in_range), f'{matched} of {len(in_range)} live stamps decoded'
    assert mismatched <= 0.02 * matched, f'{mismatched} of {matched} joint states differ'


def test_decoded_axis_states_match_the_live_ones(recorded, decoded) -> None:
    live = recorded[2]
    topics = read_topics(decoded[0])
    timeline: dict[str, list[tuple[int, tuple]]] = {}
    for stamp, msg in topics[f'{NS}/axis_states']:
        for axis in msg.axes:
            timeline.setdefault(axis.joint_name, []).append(
                (stamp, (axis.state, axis.drive_state, axis.statusword, axis.mode)))
    first = min(t[0][0] for t in timeline.values())
    compared = differ = 0
    states_seen: set[tuple[str, int]] = set()
    for msg in live:
        at = ns(msg.header.stamp)
        if at < first + 50_000_000:
            continue
        for axis in msg.axes:
            if not axis.available:
                continue
            changes = timeline[axis.joint_name]
            # the state in force from one cycle after the live publication back to when the node
            # read it: ~/axis_states is stamped when the node publishes, its snapshot crossed the
            # process boundary before (a node at nice 10 beside a benchmark: over 1.5 cycles late)
            lo = bisect.bisect_right([c[0] for c in changes], at - round((CYCLE * 1.5 + PUBLISH_LAG) * 1e9)) - 1
            hi = bisect.bisect_right([c[0] for c in changes], at + round(CYCLE * 1.5e9))
            window = {c[1] for c in changes[max(lo, 0):hi]}
            compared += 1
            differ += (axis.state, axis.drive_state, axis.statusword, axis.mode) not in window
            states_seen.add((axis.joint_name, axis.state))
    print(f'axis states: {compared} live axis states compared, {differ} not in the decoded timeline')
    assert compared > 20
    assert ('lift_joint', State.OPERATION_ENABLED) in states_seen
    assert any(j == 'lift_joint' and s != State.OPERATION_ENABLED for j, s in states_seen)
    assert differ == 0, f'{differ} of {compared} live axis states not in the decoded timeline'


def test_decode_is_faster_than_real_time_and_deterministic(recorded, decoded, tmp_path) -> None:
    bag = recorded[0]
    out, seconds = decoded
    topics = read_topics(out)
    recorded_span = (topics['/joint_states'][-1][0] - topics['/joint_states'][0][0]) / 1e9
    print(f'decode took {seconds:.2f} s for {recorded_span:.2f} s recorded')
    # about 6x faster than real time on a quiet machine: real time holds on a slow, busy one
    assert seconds < recorded_span, f'decode took {seconds:.2f} s for {recorded_span:.2f} s recorded'
    again = tmp_path / 'again'
    assert main(['replay', str(bag), '--decode', '-o', str(again), '--quiet']) == 0
    first = {t: [(s, repr(m)) for s, m in msgs] for t, msgs in topics.items()}
    second = {t: [(s, repr(m)) for s, m in msgs] for t, msgs in read_topics(again).items()}
    assert first == second


def test_decoded_emcy_and_bus_events(recorded, decoded) -> None:
    live_emcy = recorded[3]
    topics = read_topics(decoded[0])
    offline = [msg for _, msg in topics[f'{NS}/emcy']]
    assert [(m.node_id, m.error_code, m.text, m.joint_name, ns(m.header.stamp) // 1000) for m in offline] == \
        [(m.node_id, m.error_code, m.text, m.joint_name, ns(m.header.stamp) // 1000) for m in live_emcy]
    assert offline[0].error_code == 0x2310 and offline[0].joint_name == 'lift_joint'
    events = [(m.function, m.line) for _, m in topics[f'{NS}/events']]
    assert ('heartbeat_lost', 4) in events and ('heartbeat_back', 4) in events
    lost = next(s for s, m in topics[f'{NS}/events'] if m.function == 'heartbeat_lost')
    after = [m for s, m in topics['/joint_states'] if lost < s < lost + 100_000_000]
    assert after and all('lift_joint' not in m.name for m in after)


def test_decode_errors_name_what_is_wrong(recorded, tmp_path, capsys) -> None:
    bag = recorded[0]
    assert main(['replay', str(bag), '--decode']) == 2
    assert '-o OUTPUT' in capsys.readouterr().err
    trace = tmp_path / 'trace.log'
    with can.Logger(trace) as log:  # a candump log holds no bus config
        log(can.Message(timestamp=1.0, arbitration_id=0x181, data=b'\x00' * 8))
    assert main(['replay', str(trace), '--decode', '-o', str(tmp_path / 'o')]) == 2
    assert '--config' in capsys.readouterr().err
    assert main(['replay', str(tmp_path / 'missing.mcap'), '--decode', '-o', str(tmp_path / 'o')]) == 2
    assert 'missing.mcap' in capsys.readouterr().err


def test_a_trace_decodes_with_a_config_and_one_that_does_not_fit_is_refused(recorded, decoded, tmp_path,
                                                                             capsys) -> None:
    from drive_bridge.bag.source import open_recording
    bag = recorded[0]
    trace = tmp_path / 'bus.log'
    with can.Logger(trace) as log:  # candump log: microsecond stamps, no stored config
        for msg in open_recording(bag).frames():
            log(msg)
    data = yaml.safe_load(open_recording(bag).config_yaml)
    config = tmp_path / 'bus.yaml'
    config.write_text(yaml.safe_dump(data, sort_keys=False))
    out = tmp_path / 'out'
    assert main(['replay', str(trace), '--decode', '--config', str(config), '-o', str(out), '--quiet']) == 0
    from_trace = [m for _, m in read_topics(out)['/joint_states']]
    from_bag = [m for _, m in read_topics(decoded[0])['/joint_states']]
    assert len(from_trace) == len(from_bag)
    differ = [(list(a.name), list(a.position), list(b.name), list(b.position))
              for a, b in zip(from_trace, from_bag) if list(a.position) != list(b.position)]
    assert not differ, differ[:3]
    capsys.readouterr()
    data['nodes'] = {'other_drive': {'node_id': 9, 'axes': [{'joint': 'j9'}]}}
    config.write_text(yaml.safe_dump(data, sort_keys=False))
    assert main(['replay', str(trace), '--decode', '--config', str(config), '-o', str(tmp_path / 'o2')]) == 2
    assert 'does not match the recording' in capsys.readouterr().err
    assert not (tmp_path / 'o2').exists()
