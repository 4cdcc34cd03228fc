"""Recording in the bridge: a bag recorded from the simulated bus through the ROS node while
a trajectory runs and a fault is injected opens with rosbags and with mcap, has the expected
topics, types and counts, and holds exactly the frames the bus process's tap counted (its final
counts, in the snapshot the node keeps once the bus process has ended)."""
from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import DiagnosticArray
from mcap.reader import make_reader
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bridgetools import start_bridge, stop_bridge
from bustools import demo_data
from drive_bridge.bag.source import open_recording
from drive_bridge.bag.typestore import typestore
from drive_bridge.cia402.statemachine import State
from drive_bridge.ros.errors import StartupError
from drive_bridge.ros.frames import stamp_from_seconds
from drive_bridge.ros.node import BusNode
from rostools import RosHarness, wait_for

NS = '/drive_bridge'
EXPECTED_TYPES = {
    '/can/frames': 'drive_bridge_interfaces/msg/CanFrame',
    '/joint_states': 'sensor_msgs/msg/JointState',
    f'{NS}/axis_states': 'drive_bridge_interfaces/msg/AxisStates',
    f'{NS}/emcy': 'drive_bridge_interfaces/msg/Emcy',
    '/diagnostics': 'diagnostic_msgs/msg/DiagnosticArray',
    f'{NS}/events': 'rcl_interfaces/msg/Log',
    '/bag/config': 'std_msgs/msg/String',
    '/bag/files': 'diagnostic_msgs/msg/KeyValue',
}


def start_node(ros: RosHarness, tmp_path: Path, **record) -> BusNode:
    params = [Parameter('auto_enable', value=True), Parameter('diagnostics_period', value=0.2),
              Parameter('record.path', value=str(tmp_path / 'bags'))]
    params += [Parameter(f'record.{key}', value=value) for key, value in record.items()]
    node = start_bridge(ros, demo_data(), params)  # the drives simulated in the test (bridgetools)
    node.master.wait_until_operational(10.0)
    wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10, 'enabled')
    return node


def run_trajectory(ros: RosHarness, node: BusNode) -> None:
    position = node.master.axes['base_joint'].snapshot().position
    msg = JointTrajectory(joint_names=['base_joint'])
    msg.header.stamp = stamp_from_seconds(time.time() + 0.2)
    msg.points = [JointTrajectoryPoint(positions=[position + 0.3], velocities=[0.0],
                                       time_from_start=Duration(sec=0, nanosec=800_000_000))]
    ros.node('traj_pub').create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10).publish(msg)
    wait_for(lambda: abs(node.master.axes['base_joint'].snapshot().position - position - 0.3) < 2e-3, 5, 'goal')


def test_bag_of_a_trajectory_and_a_fault_has_every_frame_and_the_decoded_topics(
        ros: RosHarness, tmp_path: Path) -> None:
    node = start_node(ros, tmp_path, start=True, split_seconds=0.5)
    run_trajectory(ros, node)
    node.simulation.drive(2).inject_fault(0x2310)
    wait_for(lambda: node.master.axes['base_joint'].snapshot().fault, 3, 'fault')
    node.simulation.drive(4).restart()  # the lift drive reboots by itself
    wait_for(lambda: any(e.kind.value == 'unexpected_boot' for e in node.master.events), 5, 'reboot noticed')
    time.sleep(0.5)  # a /diagnostics with the recording status, an axis state with the fault
    stop_bridge(node)
    bag, = (tmp_path / 'bags').iterdir()
    splits = sorted(bag.glob('*.mcap'))
    assert len(splits) >= 3  # split every half second of bus time

    with AnyReader([bag], default_typestore=typestore()) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        counts: dict[str, int] = {}
        for c in reader.connections:
            counts[c.topic] = counts.get(c.topic, 0) + c.msgcount
        def topic(name: str) -> list:
            return [c for c in reader.connections if c.topic == name]
        emcy_codes = [reader.deserialize(raw, c.msgtype).error_code
                      for c, _, raw in reader.messages(topic(f'{NS}/emcy'))]
        statuses = {s.name for c, _, raw in reader.messages(topic('/diagnostics'))
                    for s in reader.deserialize(raw, c.msgtype).status}
        events = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(topic(f'{NS}/events'))]
    assert types == EXPECTED_TYPES
    assert counts['/can/frames'] > 1000
    assert counts['/joint_states'] > 200  # 4 ms cycles over > 1 s of motion
    assert counts['/bag/config'] == counts['/bag/files'] / len({n.eds_path for n in node.master.config.nodes}) \
        == len(splits)
    assert 0x2310 in emcy_codes
    assert {(e.function, e.line) for e in events} >= {('booted', 2), ('booted', 4), ('unexpected_boot', 4)}
    assert 'drive_bridge: recording' in statuses and 'drive_bridge: axis base_joint' in statuses

    mcap_frames = 0
    for split in splits:
        with split.open('rb') as stream:
            mcap = make_reader(stream)
            summary = mcap.get_summary()
            assert summary is not None and summary.statistics is not None
            frames_channel = {cid for cid, ch in summary.channels.items() if ch.topic == '/can/frames'}
            mcap_frames += sum(n for cid, n in summary.statistics.channel_message_counts.items()
                               if cid in frames_channel)
            assert {s.name for s in summary.schemas.values()} >= {'drive_bridge_interfaces/msg/CanFrame'}, \
                (split.name, [split.name for split in splits], summary.statistics.channel_message_counts,
                 {cid: ch.topic for cid, ch in summary.channels.items()})
    assert mcap_frames == counts['/can/frames']

    recording = open_recording(bag)
    assert yaml.safe_load(recording.config_yaml or '')['bus']['channel'] == node.master.config.bus.channel
    assert set(recording.files) == {n.eds_path.name for n in node.master.config.nodes if n.eds_path}
    directions = {f.is_rx for f in recording.frames()}
    assert directions == {True, False}
    # every frame the bus process's tap counted, to its end (its final counts, kept after close)
    traffic = node.master.snapshot().traffic
    assert counts['/can/frames'] == traffic.rx_frames + traffic.tx_frames, (counts['/can/frames'], traffic)


def test_record_service_starts_and_stops_and_diagnostics_report_it(ros: RosHarness, tmp_path: Path) -> None:
    node = start_node(ros, tmp_path)
    client = ros.node('record_client').create_client(SetBool, f'{NS}/record')
    diagnostics: list[DiagnosticArray] = []
    ros.node('diag_sub').create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 10)
    states: list[JointState] = []
    ros.node('js_sub').create_subscription(JointState, '/joint_states', states.append, 10)
    try:
        assert not ros.call(client, SetBool.Request(data=False)).success  # not recording
        listeners = len(node.master.frame_listeners)
        for _ in range(2):  # on/off leaves no stale recorder on the bus process's frames
            assert ros.call(client, SetBool.Request(data=True)).success
            assert len(node.master.frame_listeners) == listeners + 1
            assert ros.call(client, SetBool.Request(data=False)).success
            assert len(node.master.frame_listeners) == listeners
        started = ros.call(client, SetBool.Request(data=True))
        assert started.success and started.message.startswith(str(tmp_path / 'bags'))
        again = ros.call(client, SetBool.Request(data=True))
        assert not again.success and 'already recording' in again.message

        def recording_status(array: DiagnosticArray) -> dict[str, str] | None:
            status = next((s for s in array.status if s.name == 'drive_bridge: recording'), None)
            return {kv.key: kv.value for kv in status.values} if status else None
        wait_for(lambda: any((recording_status(a) or {}).get('recording') == 'True'
                             and int((recording_status(a) or {}).get('frames', 0)) > 0 for a in diagnostics),
                 5, 'recording status with frames in /diagnostics')
        time.sleep(0.3)
        stopped = ros.call(client, SetBool.Request(data=False))
        assert stopped.success and ' 0 dropped' in stopped.message
        frames = int(stopped.message.split(': ', 1)[1].split(' frames')[0])
        bag = Path(started.message)
        assert sum(1 for _ in open_recording(bag).frames()) == frames > 100
    finally:
        stop_bridge(node)


def test_bad_record_parameters_stop_the_node_with_the_reason(ros: RosHarness, tmp_path: Path) -> None:
    with pytest.raises(StartupError, match=r'record\.split_seconds must be >= 0, got -1'):
        BusNode(context=ros.context, parameter_overrides=[
            Parameter('config_yaml', value=yaml.safe_dump(demo_data(), sort_keys=False)),
            Parameter('record.split_seconds', value=-1.0)])
    blocker = tmp_path / 'file'
    blocker.write_text('')
    with pytest.raises(StartupError, match='cannot create the bag directory'):
        BusNode(context=ros.context, parameter_overrides=[
            Parameter('config_yaml', value=yaml.safe_dump(demo_data(), sort_keys=False)),
            Parameter('record.start', value=True), Parameter('record.path', value=str(blocker / 'bags'))])


def test_record_parameters_change_at_run_time_for_the_next_recording(ros: RosHarness, tmp_path: Path) -> None:
    node = start_node(ros, tmp_path)
    client = ros.node('param_client')
    set_params = client.create_client(SetParameters, f'{NS}/set_parameters')
    record = client.create_client(SetBool, f'{NS}/record')

    def set_param(name: str, value: object) -> tuple[bool, str]:
        result = ros.call(set_params, SetParameters.Request(
            parameters=[Parameter(name, value=value).to_parameter_msg()])).results[0]
        return result.successful, result.reason
    try:
        refused = set_param('record.split_seconds', -1.0)
        assert refused == (False, 'parameter record.split_seconds must be >= 0, got -1.0')
        assert set_param('record.path', str(tmp_path / 'other')) == (True, '')
        started = ros.call(record, SetBool.Request(data=True))
        assert started.success and started.message.startswith(str(tmp_path / 'other'))
        assert ros.call(record, SetBool.Request(data=False)).success
    finally:
        stop_bridge(node)
