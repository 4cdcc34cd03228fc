"""Fault catalogue: the bridge's node process killed with SIGKILL while its joints move. The
drives run in a process of their own (``drive-bridge sim`` over the ``local`` transport). The
node's bus process (the Master and the cycle, its child) sees its lanes close and stops every
enabled axis in a controlled way (``busproc/safestop.py``): a quick stop, at rest the drive has
left operation (or is disabled), then it ends. Only then do the drives' heartbeat consumers
(0x1016, written by the bridge at boot) miss the master's heartbeat and fault them (EMCY
0x8130): the safety net is still there, but no joint waited for it. An observer on the bus
watches, passively until the bus process has ended, by SDO afterwards."""
from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import psutil
import pytest
import yaml
from builtin_interfaces.msg import Duration
from drive_bridge_interfaces.msg import AxisStates
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bustools import DEMO, demo_data
from rostools import RosHarness, wait_for

pytestmark = [pytest.mark.sim, pytest.mark.slow,
              pytest.mark.skipif(importlib.util.find_spec('drive_bridge.cli.sim') is None,
                                 reason='needs drive-bridge sim and the local transport (branch perf)')]
REPO = Path(__file__).resolve().parent.parent
NODES = (2, 3, 4)
HEARTBEAT_ERROR = 0x8130  # CiA 301: life guard error or heartbeat error
SW_FAULT = 0x0008
# (node, controlword RPDO, statusword TPDO) of every axis of the demo (node 3: axis 1 at 0x6840/0x6841)
AXES = ((2, 0x202, 0x182), (3, 0x203, 0x183), (3, 0x403, 0x383), (4, 0x204, 0x184))
QUICK_STOP_MASK, QUICK_STOP = 0x86, 0x02  # CiA 402 device control command "quick stop"
OPERATION_ENABLED_MASK, OPERATION_ENABLED = 0x6F, 0x27


def python(*code_and_args: str) -> list[str]:
    return [sys.executable, '-c', *code_and_args]


def test_a_killed_bridge_leaves_no_drive_moving(ros: RosHarness, tmp_path: Path) -> None:
    import canopen

    from drive_bridge.master.bus import open_bus
    env = {**os.environ, 'PYTHONPATH': str(REPO), 'DRIVE_BRIDGE_CAN_DIR': str(tmp_path)}
    os.environ['DRIVE_BRIDGE_CAN_DIR'] = str(tmp_path)
    channel = f'kill-{uuid.uuid4().hex[:6]}'
    data = demo_data(channel)
    data['bus']['interface'] = 'local'
    data['simulation'] = {'enabled': False}
    config = tmp_path / 'bus.yaml'
    config.write_text(yaml.safe_dump(data))
    bridge_log = (tmp_path / 'bridge.log').open('w')  # the bus process inherits it: never a full pipe
    sim = subprocess.Popen(python('import sys; from drive_bridge.cli.main import main; sys.exit(main(sys.argv[1:]))',
                                  'sim', str(DEMO), '--interface', 'local', '--channel', channel),
                           stdout=subprocess.PIPE, stderr=(tmp_path / 'sim.log').open('w'), text=True, env=env)
    bridge = bus_process = None
    observer = canopen.Network(open_bus('local', channel))
    try:
        assert sim.stdout is not None
        assert [sim.stdout.readline().split()[1] for _ in NODES] == ['base_drive', 'arm_drive', 'lift_drive']
        frames: list[tuple[float, int, bytes]] = []
        lock = threading.Lock()

        def record(can_id: int, payload: bytearray, _stamp: float) -> None:
            with lock:
                frames.append((time.monotonic(), can_id, bytes(payload)))
        observer.connect()
        for node_id in NODES:
            observer.subscribe(0x80 + node_id, record)  # EMCY
            observer.subscribe(0x180 + node_id, record)  # TPDO1 (statusword, position)
        for _node, rpdo, tpdo in AXES:
            observer.subscribe(rpdo, record)  # the master's controlword
            observer.subscribe(tpdo, record)  # the drive's statusword
        eds = REPO / 'drive_bridge/families/generic402/data/generic402.eds'
        remote = canopen.RemoteNode(2, canopen.import_od(str(eds), 2))
        observer.add_node(remote)

        bridge = subprocess.Popen(python('from drive_bridge.cli.bridge import bridge_main; bridge_main()',
                                         str(config), '--ros-args', '-p', 'auto_enable:=true'),
                                  stdout=subprocess.DEVNULL, stderr=bridge_log, text=True, env=env)
        states: list[JointState] = []
        ros.node('kill_states').create_subscription(JointState, '/joint_states', states.append, 100)
        wait_for(lambda: states and len(states[-1].name) == 4, 30, 'joint states of the bridge process')
        start = dict(zip(states[-1].name, states[-1].position))
        move = JointTrajectory(joint_names=['base_joint', 'lift_joint'], points=[JointTrajectoryPoint(
            positions=[start['base_joint'] + 1.0, start['lift_joint'] + 0.2], time_from_start=Duration(sec=8))])
        publisher = ros.node('kill_traj').create_publisher(JointTrajectory, '/drive_bridge/joint_trajectory', 10)
        wait_for(lambda: publisher.get_subscription_count(), 10, 'the bridge subscribed')
        errors: list[String] = []
        ros.node('kill_errors').create_subscription(String, '/drive_bridge/command_errors', errors.append, 10)
        axes: list[AxisStates] = []
        ros.node('kill_axes').create_subscription(AxisStates, '/drive_bridge/axis_states', axes.append, 10)
        wait_for(lambda: axes and all(a.drive_state == a.DRIVE_ENABLED for a in axes[-1].axes), 20,
                 'every axis enabled by auto_enable')
        publisher.publish(move)
        wait_for(lambda: abs(dict(zip(states[-1].name, states[-1].position))['base_joint'] - start['base_joint'])
                 > 0.05, 10, f'base_joint moving (command errors: {[e.data for e in errors]})')
        tpdo = [f for f in frames if f[1] == 0x182][-20:]
        assert len({f[2] for f in tpdo}) > 5  # the drive reports a changing position: it moves
        bus_process = next(p for p in psutil.Process(bridge.pid).children()
                           if 'drive_bridge.busproc' in ' '.join(p.cmdline()))

        bridge.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        bridge.wait(5)

        def after_kill(cob: int) -> list[tuple[float, bytes]]:
            with lock:
                return [(t, data) for t, c, data in frames if t >= killed and c == cob]

        def quick_stopped(rpdo: int) -> float | None:
            return next((t for t, data in after_kill(rpdo)
                         if int.from_bytes(data[:2], 'little') & QUICK_STOP_MASK == QUICK_STOP), None)
        # the bus process stops every axis: a quick stop on each axis's controlword, at once
        stops = {rpdo: wait_for(lambda rpdo=rpdo: quick_stopped(rpdo), 3, f'a quick stop on 0x{rpdo:03X}')
                 for _node, rpdo, _tpdo in AXES}
        assert max(stops.values()) - killed < 1.5, {f'0x{c:03X}': round(t - killed, 3) for c, t in stops.items()}
        bus_process.wait(15)  # at rest (or out of operation) on every axis, it ends
        ended = time.monotonic()

        def heartbeat_errors() -> dict[int, float]:
            with lock:
                found: dict[int, float] = {}
                for t, cob, data in frames:
                    if t >= killed and 0x81 <= cob <= 0xFF and int.from_bytes(data[:2], 'little') == HEARTBEAT_ERROR:
                        found.setdefault(cob - 0x80, t)
                return found
        # every axis had left operation enabled before the drives' own safety net fired
        net = min(heartbeat_errors().values(), default=ended)
        for _node, _rpdo, tpdo in AXES:
            last = [int.from_bytes(data[:2], 'little') for t, data in after_kill(tpdo) if t < net][-1:]
            assert last and last[0] & OPERATION_ENABLED_MASK != OPERATION_ENABLED, \
                f'0x{tpdo:03X}: statusword {last} when the bus process was gone'
        # the net is still there: the drives' heartbeat consumers fault them once the master is silent
        wait_for(lambda: set(heartbeat_errors()) == set(NODES), 3, 'EMCY 0x8130 (heartbeat consumer) from every drive')
        assert time.monotonic() - ended < 2.0  # 300 ms consumer time + scheduling, generous
        statusword = remote.sdo.upload(0x6041, 0)
        assert int.from_bytes(statusword, 'little') & SW_FAULT
        first = remote.sdo.upload(0x6064, 0)
        time.sleep(0.3)
        assert remote.sdo.upload(0x6064, 0) == first  # at rest
    finally:
        if bridge is not None and bridge.poll() is None:
            bridge.kill()
        bridge_log.close()
        if bus_process is not None and bus_process.is_running():
            bus_process.kill()  # a failure may leave it running (it has no parent any more)
        sim.send_signal(signal.SIGTERM)
        try:
            sim.wait(10)
        finally:
            sim.kill()
            observer.disconnect()
