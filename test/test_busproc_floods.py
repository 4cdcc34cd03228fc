"""One hostile client per flood kind, against the demo while its axes stream a trajectory: the
node absorbs it (the bus process runs the cycle), so no drive faults, no heartbeat is lost,
``/joint_states`` keeps coming and the node still serves afterwards. The drives are simulated in
a process of their own (``drive-bridge sim``), as hardware would be: this test's process is the
node's, and a flood it takes in (a 100,000-point goal is deserialized by rclpy before anyone can
refuse it) would starve drives simulated here. Generous bounds for a busy 2-core machine; the
figures (skipped cycles against the core variant with the same flood beside it, the joint-state
rate) are in ``python -m bench ros_cycle --floods``."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Duration
from drive_bridge_interfaces.msg import Emcy
from drive_bridge_interfaces.srv import AxisCommand
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bench.floods import FLOODS
from bridgetools import local_data
from bustools import DEMO, demo_data
from drive_bridge.cia402.statemachine import State
from drive_bridge.master.events import EventKind
from drive_bridge.ros.node import BusNode
from rostools import RosHarness, wait_for
from timingtools import BUSY_SLACK, stamp_of

NS = '/drive_bridge'
FLOOD_SECONDS = 2.0
REPO = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.slow


@pytest.mark.parametrize('kind', FLOODS)
def test_a_flood_faults_no_drive_and_the_joint_states_go_on(ros: RosHarness, kind: str) -> None:
    data = local_data(demo_data())
    data.setdefault('options', {})['heartbeat_multiplier'] = 10  # a busy machine's stalls are not the flood's
    data['simulation'] = {'enabled': False}
    tool = Path(sys.executable).parent / 'drive-bridge'
    sim = subprocess.Popen([str(tool), 'sim', str(DEMO), '--interface', 'local', '--channel', data['bus']['channel']],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert sim.stdout is not None
    assert all('simulating' in sim.stdout.readline() for _ in range(3))
    node = None
    try:
        node = ros.add(BusNode(context=ros.context, parameter_overrides=[
            Parameter('config_yaml', value=yaml.safe_dump(data, sort_keys=False)),
            Parameter('auto_enable', value=True)]))
        node.master.wait_until_operational(10)
        wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10, 'enabled')
        watcher = ros.node(f'flood_watch_{kind}')
        states: list[JointState] = []
        emcys: list[Emcy] = []
        watcher.create_subscription(JointState, '/joint_states', states.append, 1000)
        watcher.create_subscription(Emcy, f'{NS}/emcy', emcys.append, 100)
        publisher = watcher.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
        wait_for(lambda: states and publisher.get_subscription_count(), 10, 'joint states and the bridge subscribed')
        here = dict(zip(states[-1].name, states[-1].position))
        publisher.publish(JointTrajectory(joint_names=list(here), points=[JointTrajectoryPoint(
            positions=[p + 0.1 for p in here.values()], time_from_start=Duration(sec=8))]))
        wait_for(lambda: node.trajectories.active(), 5, 'the trajectory streaming')
        # the flood in a process of its own, as a client would be (bench ros_cycle's flood role)
        flooder = subprocess.Popen([sys.executable, '-m', 'bench.ros_cycle', '--role', 'flood', '--kind', kind,
                                    '--joints', '4', '--seconds', str(FLOOD_SECONDS)],
                                   stdout=subprocess.PIPE, text=True, cwd=REPO,
                                   env={**os.environ, 'PYTHONPATH': str(REPO)})
        assert flooder.stdout is not None
        said = []  # Fast DDS may print its own warnings first (e.g. a shared-memory port busy)
        for line in flooder.stdout:
            said.append(line)
            if 'flooding' in line:
                break
        assert said and 'flooding' in said[-1], f'the flood did not start: {said}'
        started = time.time()
        assert flooder.wait(FLOOD_SECONDS + 60) == 0
        finished = time.time()
        # this process is the node's too: a flood it had to take in delays its publishing (states
        # queue at the boundary, nothing is lost); count once one stamped after the flood is here
        wait_for(lambda: states and stamp_of(states[-1]) > finished, 30, 'a joint state stamped after the flood')
        # the joint states went on: no gap longer than a busy machine's own stall, by their stamps
        stamps = sorted(stamp_of(m) for m in states if started <= stamp_of(m) <= finished)
        assert len(stamps) > 0.25 * (finished - started) / 0.004, f'{len(stamps)} joint states in the flood'
        assert max(b - a for a, b in zip(stamps, stamps[1:])) < BUSY_SLACK
        assert not emcys, [f'0x{e.error_code:04X} {e.text}' for e in emcys]
        assert not [e for e in node.master.events if e.kind is EventKind.HEARTBEAT_LOST]
        assert all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values())
        assert node.trajectories.active(), 'the trajectory stopped during the flood'
        # and the node still serves: a quick stop answers and stops
        client = watcher.create_client(AxisCommand, f'{NS}/quick_stop')
        assert ros.call(client, AxisCommand.Request(joints=['base_joint']), timeout=10).success
        assert node.master.axes['base_joint'].state in (State.QUICK_STOP_ACTIVE, State.SWITCH_ON_DISABLED)
    finally:
        if node is not None:
            node.close()
        sim.terminate()
        sim.wait(10)
