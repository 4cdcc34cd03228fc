"""The two processes of a bus node, each killed while the joints move (issue 19's failure
semantics), watched from the bus and through ROS.

The node process (``bridge``) runs as a process of its own with its bus process as its child;
the simulated drives run in this test's process on the ``local`` bus, where a sniffer records
every controlword the bridge sends.

- The node process killed (SIGKILL): its bus process brings every enabled axis to a quick stop
  at once, and once at rest disables it (``on_node_loss: disable``) or holds it in quick stop
  active (``hold``); nothing is enabled again.
- The node process dying by an unhandled exception (its executor raising while it spins, as
  an rclpy error would: the callbacks themselves are guarded): the same controlled stop.
- The node process killed while a drive that runs on by itself (the OPEN drive,
  ``runs_on_without_master``) turns: its bus process gives it its family's stop (RUN low and
  references 0, by PDO and by SDO) and keeps the bus until the drive reports it is at rest.
- The bus process killed: the node reports every joint unavailable and an ERROR on
  /diagnostics, refuses commands with that reason, and exits with code 3.
"""
from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import psutil
import pytest
import yaml
from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from drive_bridge_interfaces.msg import AxisStates
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bridgetools import local_data, simulated
from bustools import demo_data
from drive_bridge.cia402.statemachine import State
from drive_bridge.master.bus import open_bus
from rostools import RosHarness, output, spawn, wait_for

REPO = Path(__file__).resolve().parent.parent
NS = '/drive_bridge'
RPDO1 = {2: 0x202, 3: 0x203, 4: 0x204}  # controlword of axis 0 (node 3's second axis: RPDO3)
RPDO3_ARM = 0x403
QUICK_STOP_MASK, QUICK_STOP = 0x0087, 0x0002  # controlword "quick stop": bit 1 set, bits 0, 2, 7 clear
ENABLE_MASK, ENABLE_OPERATION, DISABLE_OPERATION = 0x008F, 0x000F, 0x0007
BRAKE_DELAY = 0.3  # s: base_joint's on_node_loss brake delay
OPENDRIVE_EXAMPLE = REPO / 'config' / 'opendrive_example.yaml'
OPEN_NODE = 1  # the example's OPEN drive: RPDO1 (0x201F logic word, 0x201A speed, 0x201C torque)
OPEN_RPDO1, OPEN_TPDO1, OPEN_SDO_RX, SYNC = 0x200 + OPEN_NODE, 0x180 + OPEN_NODE, 0x600 + OPEN_NODE, 0x80
RUN = 0x0001  # 0x201F bit 0
AT_REST_UNITS = 16  # |0x2012[0]| at most this: at rest (the family's own threshold)


class Sniffer:
    """Every frame on the local bus with its arrival time (monotonic)."""

    def __init__(self, channel: str) -> None:
        self.bus = open_bus('local', channel)
        self.frames: list[tuple[float, int, bytes]] = []
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop:
            msg = self.bus.recv(0.05)
            if msg is not None:
                self.frames.append((time.monotonic(), msg.arbitration_id, bytes(msg.data)))

    def controlwords(self, cob_id: int, since: float) -> list[tuple[float, int]]:
        return [(t, int.from_bytes(d[:2], 'little')) for t, c, d in list(self.frames) if c == cob_id and t >= since]

    def close(self) -> None:
        self._stop = True
        self._thread.join(2)
        self.bus.shutdown()


BRIDGE = 'from drive_bridge.cli.bridge import bridge_main; bridge_main()'
# the bridge whose executor raises in its spin once the file DRIVE_BRIDGE_TEST_RAISE names exists
# (a wrapper of this test: no hook in the bridge)
RAISING_BRIDGE = """
import os
from rclpy.executors import SingleThreadedExecutor
from drive_bridge.cli.bridge import bridge_main

trigger = os.environ['DRIVE_BRIDGE_TEST_RAISE']
spin_once = SingleThreadedExecutor.spin_once

def raising_spin_once(self, timeout_sec=None):
    if os.path.exists(trigger):
        raise RuntimeError('injected by the test: an unhandled exception in the spinning node')
    return spin_once(self, timeout_sec)

SingleThreadedExecutor.spin_once = raising_spin_once
bridge_main()
"""


@contextmanager
def bridge_process(tmp_path: Path, data: dict[str, Any], *params: str, program: str = BRIDGE,
                   ) -> Iterator[tuple[subprocess.Popen[str], Any, Sniffer]]:
    """The node process (with its bus process) on a local bus, the simulated drives here;
    ``params``: more ROS parameters (``name:=value``); ``program``: what ``python -c`` runs."""
    data = local_data(data)
    # the drives run in this test's process, beside its ROS harness: on a busy 2-core machine a
    # stall of it over 300 ms lost heartbeats both ways (EMCY 0x8130, the trajectory refused)
    data.setdefault('options', {})['heartbeat_multiplier'] = 10
    sim = simulated(data)
    sniffer = Sniffer(data['bus']['channel'])
    bridge_data = {**data, 'simulation': {'enabled': False}}
    config = tmp_path / 'bus.yaml'
    config.write_text(yaml.safe_dump(bridge_data, sort_keys=False))
    env = {**os.environ, 'PYTHONPATH': str(REPO)}
    bridge = spawn([sys.executable, '-c', program, str(config), '--ros-args', '-p', 'auto_enable:=true',
                    *(arg for param in params for arg in ('-p', param))], tmp_path / 'bridge.log', env=env)
    try:
        yield bridge, sim, sniffer
    finally:
        for process in [*bus_processes(bridge), *_seen.pop(bridge.pid, [])]:
            try:
                process.kill()  # a bus process that holds an axis runs until told (here: killed)
            except psutil.NoSuchProcess:
                pass
        if bridge.poll() is None:
            bridge.kill()
        bridge.wait(10)
        sniffer.close()
        sim.stop()


_seen: dict[int, list[psutil.Process]] = {}


def bus_processes(bridge: subprocess.Popen[str]) -> list[psutil.Process]:
    """The bridge's bus process(es), remembered: once the bridge is gone they are no one's children."""
    try:
        found = [p for p in psutil.Process(bridge.pid).children() if 'drive_bridge.busproc' in ' '.join(p.cmdline())]
    except psutil.NoSuchProcess:
        return []
    _seen.setdefault(bridge.pid, []).extend(p for p in found if p not in _seen.get(bridge.pid, []))
    return found


def enabled_and_moving(ros: RosHarness, sim: Any) -> None:
    """Every axis enabled by auto_enable, then a slow trajectory on every joint."""
    axes: list[AxisStates] = []
    ros.node('fail_axes').create_subscription(AxisStates, f'{NS}/axis_states', axes.append, 10)
    wait_for(lambda: axes and len(axes[-1].axes) == 4 and all(a.drive_state == a.DRIVE_ENABLED for a in axes[-1].axes),
             40, 'every axis enabled by auto_enable')
    joints = [a.joint_name for a in axes[-1].axes]
    node = ros.node('fail_traj')
    publisher = node.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    errors: list[String] = []
    node.create_subscription(String, f'{NS}/command_errors', errors.append, 10)
    wait_for(lambda: publisher.get_subscription_count(), 10, 'the bridge subscribed')
    here = {2: sim.drive(2).axis(0).position}
    publisher.publish(JointTrajectory(joint_names=joints, points=[JointTrajectoryPoint(
        positions=[0.8, 0.5, -0.5, 0.2], time_from_start=Duration(sec=6))]))
    wait_for(lambda: abs(sim.drive(2).axis(0).position - here[2]) > 2000, 10,
             f'base_joint moving (command errors: {[e.data for e in errors]})')


def test_the_node_killed_its_bus_process_quick_stops_every_axis_then_disables_or_holds(
        ros: RosHarness, tmp_path: Path) -> None:
    data = demo_data()
    # lift: holds in quick stop active (a vertical axis); the drive stays there at rest (0x605A = 6)
    lift = data['nodes']['lift_drive']
    lift['axes'][0]['on_node_loss'] = {'action': 'hold'}
    lift['sdo'] = [{'index': 0x605A, 'sub_index': 0, 'value': 6}]
    # base: disabled after the brake delay, from quick stop active (the drive stays there too)
    base = data['nodes']['base_drive']
    base['axes'][0]['on_node_loss'] = {'action': 'disable', 'brake_delay': BRAKE_DELAY}
    base['sdo'] = [{'index': 0x605A, 'sub_index': 0, 'value': 6}]
    with bridge_process(tmp_path, data) as (bridge, sim, sniffer):
        enabled_and_moving(ros, sim)
        bus, = bus_processes(bridge)
        os.kill(bridge.pid, signal.SIGKILL)
        killed = time.monotonic()
        bridge.wait(5)

        def stopped(cob_id: int) -> float | None:
            return next((t for t, cw in sniffer.controlwords(cob_id, killed)
                         if cw & QUICK_STOP_MASK == QUICK_STOP), None)
        wait_for(lambda: all(stopped(c) for c in (*RPDO1.values(), RPDO3_ARM)), 2,
                 'a quick-stop controlword to every axis')
        assert max(stopped(c) for c in (*RPDO1.values(), RPDO3_ARM)) - killed < 1.0  # goal 0.1 s: bench
        # base: quick stop active, at rest, then disabled; never enabled again
        wait_for(lambda: sim.drive(2).axis(0).state is State.SWITCHED_ON, 5, 'base_joint disabled')
        base_words = sniffer.controlwords(RPDO1[2], stopped(RPDO1[2]) or killed)
        assert not [cw for _, cw in base_words if cw & ENABLE_MASK == ENABLE_OPERATION]
        # in that order on the bus: quick stop, kept until at rest and the brake delay has passed,
        # then the words that disable it (a stall of this test's sniffer may shorten the gap it sees)
        leaving = next(t for t, cw in base_words if cw & QUICK_STOP_MASK != QUICK_STOP)
        assert leaving - base_words[0][0] >= BRAKE_DELAY / 2, f'disabled {leaving - base_words[0][0]:.3f} s after'
        # lift: held in quick stop active, at rest, with the bus alive (its heartbeat consumer content)
        assert sim.drive(4).axis(0).state is State.QUICK_STOP_ACTIVE
        held = sim.drive(4).axis(0).position
        time.sleep(0.5)
        assert sim.drive(4).axis(0).state is State.QUICK_STOP_ACTIVE and sim.drive(4).axis(0).position == held
        lift_words = sniffer.controlwords(RPDO1[4], stopped(RPDO1[4]) or killed)  # quick stop, and only that
        assert len(lift_words) > 10 and all(cw & QUICK_STOP_MASK == QUICK_STOP for _, cw in lift_words)
        assert bus.is_running()
        # the others (option code 2): disabled, by the drive itself at the end of its quick stop or
        # by the bridge once at rest; never enabled again
        for node_id, slot, cob_id in ((3, 0, RPDO1[3]), (3, 1, RPDO3_ARM)):
            wait_for(lambda: sim.drive(node_id).axis(slot).state in (State.SWITCH_ON_DISABLED, State.SWITCHED_ON),
                     5, f'node {node_id} axis {slot} disabled ({sim.drive(node_id).axis(slot).state})')
            words = sniffer.controlwords(cob_id, stopped(cob_id) or killed)
            assert not [cw for _, cw in words if cw & ENABLE_MASK == ENABLE_OPERATION]
        bus.send_signal(signal.SIGTERM)  # ends the hold: the bus process releases the bus
        bus.wait(10)  # ended (its exit code goes to whoever adopted it)
        assert not bus.is_running()


def test_the_node_dying_by_an_unhandled_exception_quick_stops_every_axis_then_disables_it_at_rest(
        ros: RosHarness, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    trigger = tmp_path / 'raise'
    monkeypatch.setenv('DRIVE_BRIDGE_TEST_RAISE', str(trigger))
    data = demo_data()
    # base and lift stay in quick stop active at the end of it (0x605A = 6): only the bridge's
    # disable, once at rest and after the brake delay, takes them out of it
    for name in ('base_drive', 'lift_drive'):
        node = data['nodes'][name]
        node['axes'][0]['on_node_loss'] = {'action': 'disable', 'brake_delay': BRAKE_DELAY}
        node['sdo'] = [{'index': 0x605A, 'sub_index': 0, 'value': 6}]
    with bridge_process(tmp_path, data, program=RAISING_BRIDGE) as (bridge, sim, sniffer):
        enabled_and_moving(ros, sim)
        bus, = bus_processes(bridge)
        trigger.touch()
        raised = time.monotonic()
        assert bridge.wait(15) != 0
        assert 'injected by the test: an unhandled exception in the spinning node' in output(bridge)

        def stopped(cob_id: int) -> float | None:
            return next((t for t, cw in sniffer.controlwords(cob_id, raised)
                         if cw & QUICK_STOP_MASK == QUICK_STOP), None)
        wait_for(lambda: all(stopped(c) for c in (*RPDO1.values(), RPDO3_ARM)), 5,
                 'a quick-stop controlword to every axis')
        bus.wait(20)  # no axis holds: it ends once every axis is stopped and disabled (then the
        # drives' heartbeat consumers see the master go and fault: the state to check is on the bus)
        for joint, cob_id in (('base_joint', RPDO1[2]), ('lift_joint', RPDO1[4])):
            words = sniffer.controlwords(cob_id, stopped(cob_id) or raised)
            assert not [cw for _, cw in words if cw & ENABLE_MASK == ENABLE_OPERATION], f'{joint} enabled again'
            # quick stop, kept until at rest and the brake delay has passed, then disabled (out of
            # quick stop active by 'disable voltage', on to switched on: operation disabled)
            leaving = next((t for t, cw in words if cw & QUICK_STOP_MASK != QUICK_STOP), None)
            assert leaving is not None, f'{joint} left in quick stop active: never disabled'
            assert DISABLE_OPERATION in {cw & ENABLE_MASK for t, cw in words if t >= leaving}, f'{joint} not disabled'
            assert leaving - words[0][0] >= BRAKE_DELAY / 2, f'{joint} disabled {leaving - words[0][0]:.3f} s after'
            assert f'{joint}: quick stop, at rest, disabled after the 300 ms brake delay' in output(bridge)
        for cob_id in (RPDO1[3], RPDO3_ARM):  # option code 2: disabled by the drive or the bridge
            words = sniffer.controlwords(cob_id, stopped(cob_id) or raised)
            assert not [cw for _, cw in words if cw & ENABLE_MASK == ENABLE_OPERATION]
        assert 'node process lost' in output(bridge)  # the bus process's log: its node-loss stop


def test_the_node_killed_a_drive_that_runs_on_by_itself_gets_its_family_stop_until_at_rest(
        ros: RosHarness, tmp_path: Path) -> None:
    data = yaml.safe_load(OPENDRIVE_EXAMPLE.read_text())
    node = data['nodes']['opendrive']
    node['command_timeout_ms'] = 60000  # the dead-man does not stop it first
    # node life time 1 s (the example's 300 ms): the drive runs in this test's process, and a stall
    # of it on a busy machine lost the guarding (the node then unavailable when the node died)
    node['life_time_factor'] = 10
    with bridge_process(tmp_path, data, 'command_interface:=velocity') as (bridge, sim, sniffer):
        drive = sim.drive(OPEN_NODE)
        axes: list[AxisStates] = []
        ros.node('fail_open_axes').create_subscription(AxisStates, f'{NS}/axis_states', axes.append, 10)
        wait_for(lambda: axes and all(a.drive_state == a.DRIVE_ENABLED for a in axes[-1].axes), 40,
                 'the spindle enabled by auto_enable')
        commands = ros.node('fail_open_cmd').create_publisher(Float64MultiArray, f'{NS}/commands', 10)
        wait_for(lambda: commands.get_subscription_count(), 10, 'the bridge subscribed')
        for _ in range(5):
            commands.publish(Float64MultiArray(data=[50.0]))  # rad/s: 477.5 rpm
            time.sleep(0.05)
        wait_for(lambda: abs(drive.speed_rpm - 477.5) < 5, 10, 'the motor at 477.5 rpm')
        bus, = bus_processes(bridge)
        os.kill(bridge.pid, signal.SIGKILL)
        killed = time.monotonic()
        bridge.wait(5)
        bus.wait(20)  # no axis holds: it ends once the drive is stopped
        ended = time.monotonic()
        assert abs(drive.speed_rpm) < 1 and not drive.running
        words = [(t, struct.unpack('<Ihh', d)) for t, c, d in list(sniffer.frames) if c == OPEN_RPDO1 and t >= killed]
        stop = next((t for t, (word, speed, torque) in words if not word & RUN and speed == torque == 0), None)
        assert stop is not None and stop - killed < 1.0, 'RUN low and references 0 by PDO within 1 s'
        assert all(not word & RUN for t, (word, _s, _t) in words if t >= stop), 'RUN high again after the stop'
        sdo = [d for t, c, d in list(sniffer.frames) if c == OPEN_SDO_RX and t >= killed and d[1:3] == b'\x1f\x20']
        assert sdo, 'the family stop by SDO (0x201F) as well'
        assert all(int.from_bytes(d[4:8], 'little') & RUN == 0 for d in sdo)
        # the bus kept (SYNC) until the drive reported it was at rest: nothing was left running on
        at_rest = next((t for t, c, d in list(sniffer.frames) if c == OPEN_TPDO1 and t >= stop
                        and abs(struct.unpack_from('<h', d, 6)[0]) <= AT_REST_UNITS), None)
        assert at_rest is not None, 'the drive never reported rest while the bus process ran'
        last_sync = max(t for t, c, _d in list(sniffer.frames) if c == SYNC)
        assert at_rest <= last_sync <= ended
        assert "spindle_joint: quick stop and its family's stop, at rest" in output(bridge)  # the bus process's log


def test_the_bus_process_killed_the_node_reports_every_joint_unavailable_and_exits(
        ros: RosHarness, tmp_path: Path) -> None:
    with bridge_process(tmp_path, demo_data()) as (bridge, sim, _sniffer):
        enabled_and_moving(ros, sim)
        diagnostics: list[DiagnosticArray] = []
        ros.node('fail_diag').create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 50)
        axes: list[AxisStates] = []
        ros.node('fail_axes2').create_subscription(AxisStates, f'{NS}/axis_states', axes.append, 50)
        errors: list[String] = []
        ros.node('fail_errors').create_subscription(String, f'{NS}/command_errors', errors.append, 50)
        commands = ros.node('fail_cmd').create_publisher(Float64MultiArray, f'{NS}/commands', 10)
        wait_for(lambda: diagnostics, 10, 'diagnostics')
        bus, = bus_processes(bridge)
        bus.kill()
        killed = time.monotonic()

        def bus_error() -> DiagnosticStatus | None:
            return next((s for array in list(diagnostics) for s in array.status
                         if s.name.startswith('drive_bridge: bus') and s.level == DiagnosticStatus.ERROR), None)
        status = wait_for(bus_error, 5, 'an ERROR on /diagnostics')
        assert time.monotonic() - killed < 1.0  # goal 0.3 s: bench
        assert 'bus process lost' in status.message and 'signal 9' in status.message
        unavailable = wait_for(lambda: next((m for m in reversed(axes) if all(not a.available for a in m.axes)), None),
                               2, 'every joint unavailable on ~/axis_states')
        assert all('bus process lost' in a.message for a in unavailable.axes)
        commands.publish(Float64MultiArray(data=[0.0, 0.0, 0.0, 0.0]))
        refusal = wait_for(lambda: next((e for e in errors if 'bus process lost' in e.data), None), 2,
                           'the command refused with the reason')
        assert refusal.data.startswith('~/commands: refused: bus process lost')
        assert bridge.wait(10) == 3
        assert 'bus process lost' in output(bridge)


@pytest.fixture(autouse=True)
def _own_can_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The local bus's sockets in this test's directory (the bridge process inherits it)."""
    monkeypatch.setenv('DRIVE_BRIDGE_CAN_DIR', str(tmp_path))
