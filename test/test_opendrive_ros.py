"""The OPEN drive through ROS alone: a bus node with the shipped example (one simulated OPEN
drive, CiA 301 only) runs in-process on a private rclpy context; the test talks to it through
topics and services, records the CAN frames (akdtools.Sniffer) and inspects the simulator to
see what reached the drive. Timing bounds are generous (noisy 2-core CI).

Figures: n_MAX 3000 rpm, so 16384 in 0x201A = 314.16 rad/s; T_nom 10 N·m = 4095 in 0x201C.
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
from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import DiagnosticArray
from drive_bridge_interfaces.msg import AxisState, AxisStates
from drive_bridge_interfaces.srv import AxisCommand, ParamRead, ParamSave, ParamWrite, SetMode
from rcl_interfaces.msg import Log
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from akdtools import Sniffer
from bridgetools import local_data, node_snapshot, start_bridge, stop_bridge
from rostools import RosHarness, wait_for
from timingtools import BUSY_SLACK

NS = '/drive_bridge'
EXAMPLE = Path(__file__).resolve().parent.parent / 'config' / 'opendrive_example.yaml'
NODE = 1
JOINT = 'spindle_joint'
RPDO1 = 0x200 + NODE
RUN = 1
SPEED_UNIT = 3000 * 2 * math.pi / 60 / 16384  # rad/s per unit of 0x201A


def config_data(simulation: dict[str, Any] | None = None, **node: Any) -> dict[str, Any]:
    """The example on a local bus of its own (bridgetools: its simulated drive in the test)."""
    data = local_data(yaml.safe_load(EXAMPLE.read_text()))
    data['nodes']['opendrive'].update(node)
    if simulation:
        data['simulation'] = {'enabled': True, 'nodes': {'opendrive': simulation}}
    data['access'] = {'param_save': 'configured'}  # ROS clients may not save by default
    return data


class Bench:
    """The bus node, a frame recorder and topic recorders."""

    def __init__(self, ros: RosHarness, interface: str = 'velocity', simulation: dict[str, Any] | None = None,
                 **node: Any) -> None:
        data = config_data(simulation, **node)
        self.ros = ros
        self.sniffer = Sniffer(data['bus']['channel'], interface='local')  # on the bus before the bridge
        try:
            self.node = start_bridge(ros, data, [Parameter('command_interface', value=interface)])
        except Exception:
            self.sniffer.close()
            raise
        self.states: list[JointState] = []
        self.axis_states: list[AxisStates] = []
        self.logs: list[Log] = []
        self.errors: list[String] = []
        self.diagnostics: list[DiagnosticArray] = []
        watcher = ros.node(f'od_watch_{time.monotonic_ns() % 1000000}')
        self.arrivals: list[float] = []  # monotonic time each joint state with the joint arrived
        watcher.create_subscription(JointState, '/joint_states', self._on_state, 100)
        watcher.create_subscription(AxisStates, f'{NS}/axis_states', self.axis_states.append, 100)
        watcher.create_subscription(Log, '/rosout', self.logs.append, 100)
        watcher.create_subscription(String, f'{NS}/command_errors', self.errors.append, 100)
        watcher.create_subscription(DiagnosticArray, '/diagnostics', self.diagnostics.append, 10)
        self.publisher = watcher.create_publisher(Float64MultiArray, f'{NS}/commands', 10)
        self.watcher = watcher
        self.node.master.wait_until_operational(15.0)
        wait_for(lambda: any(JOINT in m.name for m in self.states), 10, f'{JOINT} in /joint_states')

    def _on_state(self, msg: JointState) -> None:
        self.states.append(msg)
        if JOINT in msg.name:
            self.arrivals.append(time.monotonic())

    @property
    def drive(self) -> Any:
        return self.node.simulation.drive(NODE)

    def call(self, srv_type: Any, name: str, **fields: Any) -> Any:
        client = self.watcher.create_client(srv_type, f'{NS}/{name}')
        return self.ros.call(client, srv_type.Request(**fields), timeout=15.0)

    def axis(self, name: str, **fields: Any) -> Any:
        return self.call(AxisCommand, name, joints=[JOINT], **fields)

    def rpdos(self, after: int = 0) -> list[tuple[int, int, int]]:
        """(0x201F, 0x201A, 0x201C) of every RPDO1 sent."""
        return [struct.unpack('<Ihh', f.data) for f in self.sniffer.frames(RPDO1, after)]

    def last_axis_state(self) -> AxisState | None:
        return self.axis_states[-1].axes[0] if self.axis_states else None

    def close(self) -> None:
        try:
            stop_bridge(self.node)
        finally:
            self.sniffer.close()


@pytest.fixture
def bench(ros: RosHarness) -> Iterator[Bench]:
    bench = Bench(ros, guard_time_ms=50, life_time_factor=3, command_timeout_ms=300)
    try:
        yield bench
    finally:
        bench.close()


def test_guarded_without_heartbeat_lost_within_the_life_time_and_back_disabled(bench: Bench) -> None:
    assert bench.axis('enable').success
    for _ in range(5):
        bench.publisher.publish(Float64MultiArray(data=[20.0]))
        time.sleep(0.02)
    time.sleep(1.0)  # answering: never declared lost (no heartbeat at all)
    assert node_snapshot(bench.node, 'opendrive', fresh=True).available
    assert not any('lost' in m.msg for m in bench.logs)
    bench.drive.stop_guarding_replies(True)
    silent = time.monotonic()
    wait_for(lambda: next((m for m in bench.logs if 'guarding' in m.msg and 'lost' in m.msg), None), 3,
             'a guarding-lost log')
    time.sleep(0.5)
    # the last joint state with the joint came within the life time (150 ms, plus the supervisor's
    # poll and a busy machine), none after
    assert bench.arrivals[-1] - silent < 0.15 + BUSY_SLACK
    recent = len(bench.states)
    time.sleep(0.3)
    assert all(JOINT not in m.name for m in bench.states[recent:]), 'the lost joint is still published'
    wait_for(lambda: bench.last_axis_state() is not None and not bench.last_axis_state().available, 2,
             'axis state unavailable')
    assert bench.last_axis_state().drive_state == AxisState.DRIVE_UNAVAILABLE
    mark = bench.sniffer.mark
    bench.drive.stop_guarding_replies(False)
    wait_for(lambda: any(JOINT in m.name for m in bench.states[recent:]), 10, f'{JOINT} back in /joint_states')
    first = wait_for(lambda: bench.rpdos(mark), 2, 'an RPDO1 after the node came back')[0]
    assert first == (0, 0, 0), first  # the first frames after it came back: RUN 0, references 0
    time.sleep(0.5)
    assert all(word & RUN == 0 for word, _s, _t in bench.rpdos(mark))
    assert bench.last_axis_state().drive_state != AxisState.DRIVE_ENABLED, 're-enabled by itself'
    assert not bench.drive.run_input


def test_commands_dead_man_halt_disable_and_refusals(bench: Bench) -> None:
    drive = bench.drive
    assert bench.axis('enable').success
    wait_for(lambda: bench.last_axis_state() is not None
             and bench.last_axis_state().drive_state == AxisState.DRIVE_ENABLED, 3, 'enabled on ~/axis_states')
    state = bench.last_axis_state()
    assert (state.state, state.statusword, state.controlword, state.mode_name) == (AxisState.STATE_UNKNOWN, 0, 0,
                                                                                  'pv')
    # velocity in rad/s: 100 -> 0x201A = 5215 -> 954.9 rpm at the motor
    for _ in range(40):
        bench.publisher.publish(Float64MultiArray(data=[100.0]))
        last = time.monotonic()
        time.sleep(0.02)
    assert bench.rpdos()[-1] == (RUN, 5215, 0)
    # the drive takes the frame in its own thread: the sniffer may have it first on a busy machine
    wait_for(lambda: drive.speed_reference_rpm == pytest.approx(954.9, abs=0.1), 2, 'the reference 954.9 rpm')
    wait_for(lambda: abs(drive.speed_rpm - 954.9) < 2, 3, 'the motor at 954.9 rpm')
    velocity = dict(zip(bench.states[-1].name, bench.states[-1].velocity))[JOINT]
    assert velocity == pytest.approx(100.0, abs=0.5)
    # the stream stops: after command_timeout_ms (300) 0x201A = 0 and the joint is stale
    wait_for(lambda: bench.rpdos()[-1] == (RUN, 0, 0), 2, '0x201A = 0 from the dead-man')
    assert time.monotonic() - last > 0.25  # not before the 300 ms since the last command
    wait_for(lambda: any(s.name.endswith(JOINT) and 'no command for 300 ms' in s.message
                         for d in bench.diagnostics for s in d.status), 5, 'stale on /diagnostics')
    snapshot = bench.node.master.axes[JOINT].snapshot()
    assert snapshot.command_stale and '0x201A = 0' in snapshot.message
    state = wait_for(lambda: bench.last_axis_state() if bench.last_axis_state().command_stale else None, 2,
                     'stale on ~/axis_states')
    assert '0x201A = 0' in state.message and state.drive_state == AxisState.DRIVE_ENABLED

    # beyond the drive's range (2 n_MAX = 628 rad/s; the joint limit is 300): refused, never wrapped
    bench.publisher.publish(Float64MultiArray(data=[299.0 * 3]))
    wait_for(lambda: bench.errors, 3, 'a command error')
    assert 'exceeds the limit 300' in bench.errors[-1].data
    bench.publisher.publish(Float64MultiArray(data=[50.0]))
    wait_for(lambda: bench.rpdos()[-1] == (RUN, round(50 / SPEED_UNIT), 0), 2, 'a command again')
    # ~/halt: references 0, RUN kept
    assert bench.axis('halt').success
    wait_for(lambda: bench.rpdos()[-1] == (RUN, 0, 0), 2, 'halted')
    wait_for(lambda: abs(drive.speed_rpm) < 5, 3, 'the motor stopped')
    assert drive.running
    assert bench.axis('resume').success
    # ~/disable: 0x201A = 0 and RUN 0 in one RPDO
    for _ in range(10):
        bench.publisher.publish(Float64MultiArray(data=[20.0]))
        time.sleep(0.02)
    raw = round(20 / SPEED_UNIT)
    assert bench.rpdos()[-1] == (RUN, raw, 0)
    mark = bench.sniffer.mark
    assert bench.axis('disable').success
    changed = wait_for(lambda: next((f for f in bench.rpdos(mark) if f != (RUN, raw, 0)), None), 1,
                       'the disabling RPDO')  # the sniffer sees frames on its own thread
    assert changed == (0, 0, 0)
    assert not drive.run_input
    # refused, naming the family
    home = bench.axis('home')
    assert not home.success and "family 'opendrive' has no homing" in home.message
    mode = bench.call(SetMode, 'set_mode', joints=[JOINT], mode='csp')
    assert not mode.success and "family 'opendrive' has no mode csp" in mode.message
    assert bench.call(SetMode, 'set_mode', joints=[JOINT], mode='pt').success
    assert bench.call(SetMode, 'set_mode', joints=[JOINT], mode='pv').success


def test_a_velocity_trajectory_is_streamed_as_speed_references(bench: Bench) -> None:
    drive = bench.drive
    assert bench.axis('enable').success
    publisher = bench.watcher.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    msg = JointTrajectory(joint_names=[JOINT])  # velocity only: 50 rad/s for a second, then rest
    msg.points = [JointTrajectoryPoint(velocities=[50.0], time_from_start=Duration(sec=0, nanosec=200_000_000)),
                  JointTrajectoryPoint(velocities=[50.0], time_from_start=Duration(sec=1, nanosec=200_000_000)),
                  JointTrajectoryPoint(velocities=[0.0], time_from_start=Duration(sec=1, nanosec=400_000_000))]
    wait_for(lambda: publisher.get_subscription_count() > 0, 5, 'the bridge subscribed')
    publisher.publish(msg)
    raw = round(50.0 / SPEED_UNIT)  # 2608: 477.5 rpm
    wait_for(lambda: bench.rpdos() and bench.rpdos()[-1] == (RUN, raw, 0), 3, '0x201A = 2608 from the trajectory')
    wait_for(lambda: abs(drive.speed_rpm - 477.5) < 2, 3, 'the motor at 477.5 rpm')
    wait_for(lambda: bench.rpdos()[-1] == (RUN, 0, 0), 3, 'back to rest at the end')
    assert not bench.errors
    assert bench.node.master.axes[JOINT].drive_state.label == 'enabled'
    # positions only: nothing to follow without a position reference, refused with the family named
    msg = JointTrajectory(joint_names=[JOINT])
    msg.points = [JointTrajectoryPoint(positions=[1.0], time_from_start=Duration(sec=1))]
    publisher.publish(msg)
    wait_for(lambda: bench.errors, 3, 'a refusal')
    assert "family 'opendrive' has no position reference" in bench.errors[-1].data, bench.errors[-1].data


def test_position_commands_are_refused_with_the_family_named(ros: RosHarness) -> None:
    bench = Bench(ros, interface='position', guard_time_ms=50)
    try:
        assert bench.axis('enable').success
        bench.publisher.publish(Float64MultiArray(data=[1.0]))
        wait_for(lambda: bench.errors, 3, 'a command error')
        assert "family 'opendrive' takes no position commands" in bench.errors[-1].data
        assert all(speed == 0 for _w, speed, _t in bench.rpdos())
    finally:
        bench.close()


def test_effort_in_newton_metres_and_the_bridge_stops_the_drive_before_leaving(ros: RosHarness) -> None:
    bench = Bench(ros, interface='effort', simulation={'control_mode': 'torque'}, guard_time_ms=50)
    closed = False
    try:
        drive = bench.drive
        assert bench.call(SetMode, 'set_mode', joints=[JOINT], mode='pt').success
        assert bench.axis('enable').success
        for _ in range(20):  # 2.5 N·m -> 0x201C = 1024 (2.5 / 10 * 4095 = 1023.75)
            bench.publisher.publish(Float64MultiArray(data=[2.5]))
            time.sleep(0.02)
        assert bench.rpdos()[-1] == (RUN, 0, 1024)
        wait_for(lambda: drive.torque_nm == pytest.approx(1024 / 4095 * 10.0), 2, 'the drive at 0x201C = 1024')
        wait_for(lambda: abs(dict(zip(bench.states[-1].name, bench.states[-1].effort))[JOINT] - 2.5) < 0.01, 2,
                 'the effort on /joint_states')
        bench.publisher.publish(Float64MultiArray(data=[25.0]))  # the example's max_effort is 20
        wait_for(lambda: bench.errors, 3, 'a command error')
        assert 'exceeds the limit 20' in bench.errors[-1].data
        for _ in range(5):
            bench.publisher.publish(Float64MultiArray(data=[2.5]))
            time.sleep(0.02)
        assert drive.running
        bench.node.close()
        closed = True
        assert bench.rpdos()[-1] == (0, 0, 0)  # the last frame before the bus was let go
        assert not drive.run_input
    finally:
        if not closed:
            bench.node.close()
        bench.sniffer.close()


def test_fault_reset_names_the_alarm_while_its_cause_persists(bench: Bench) -> None:
    drive = bench.drive
    assert bench.axis('enable').success
    drive.inject_alarm(4, persistent=True)
    wait_for(lambda: bench.last_axis_state() is not None
             and bench.last_axis_state().drive_state == AxisState.DRIVE_FAULT, 3, 'fault on ~/axis_states')
    state = bench.last_axis_state()
    assert state.fault and state.last_error_code == 0x1000 and state.last_error_text == 'alarm A4 temperature'
    failed = bench.axis('fault_reset', timeout=0.5)
    assert not failed.success and 'alarm A4 temperature still active' in failed.message
    drive.clear_alarm_cause(4)
    done = bench.axis('fault_reset', timeout=2.0)
    assert done.success, done.message
    assert drive.alarms == 0
    wait_for(lambda: bench.last_axis_state().drive_state == AxisState.DRIVE_DISABLED, 3, 'disabled after the reset')
    assert not drive.running


def test_parameters_through_ros(bench: Bench) -> None:
    drive = bench.drive
    read = bench.call(ParamRead, 'param_read', joint=JOINT, parameter='P1')
    assert read.success, read.message
    assert (read.value_text, read.unit, read.minimum, read.access) == ('100.0', '%', 0.0, 'free (on-line)')
    assert read.maximum == pytest.approx(200.0) and read.has_range
    assert bench.axis('enable').success
    running = bench.call(ParamWrite, 'param_write', joint=JOINT, parameter='P2', value='50')
    assert not running.success and 'Reserved parameter' in running.message and 'running' in running.message
    assert bench.axis('disable').success
    no_key = bench.call(ParamWrite, 'param_write', node_id=NODE, parameter='P2', value='50')
    assert not no_key.success and 'P60 is 0' in no_key.message
    assert bench.call(ParamWrite, 'param_write', node_id=NODE, parameter='P60', value='1').success
    high = bench.call(ParamWrite, 'param_write', node_id=NODE, parameter='P2', value='150')
    assert not high.success and 'outside the range 0.5..100' in high.message and 'nothing was sent' in high.message
    assert drive.parameter(2) == 400
    written = bench.call(ParamWrite, 'param_write', node_id=NODE, parameter='P2', value='50')
    assert written.success, written.message
    assert written.value == 50.0 and drive.parameter(2) == 500
    saved = bench.call(ParamSave, 'param_save', joint=JOINT)
    assert saved.success and 'C63 = 1' in saved.message and drive.saved_parameter(2) == 500
