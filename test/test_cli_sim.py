"""``drive-bridge sim``: the demo's drives in a process of their own, driven by the bridge
through ROS over the ``local`` CAN transport."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Duration
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bustools import DEMO, demo_data
from drive_bridge.cia402.statemachine import State
from drive_bridge.cli.main import main
from drive_bridge.ros.frames import stamp_from_seconds
from drive_bridge.ros.node import BusNode
from rostools import RosHarness, wait_for

pytestmark = pytest.mark.sim  # the drives of `drive-bridge sim`, in a process of their own
REPO = Path(__file__).resolve().parent.parent
TOOL = Path(sys.executable).parent / 'drive-bridge'


def start_sim(config: Path, channel: str, can_dir: Path) -> subprocess.Popen[str]:
    env = {**os.environ, 'PYTHONPATH': str(REPO), 'DRIVE_BRIDGE_CAN_DIR': str(can_dir)}
    return subprocess.Popen([str(TOOL), 'sim', str(config), '--interface', 'local', '--channel', channel],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def test_the_bridge_boots_and_moves_drives_hosted_by_drive_bridge_sim(
        ros: RosHarness, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv('DRIVE_BRIDGE_CAN_DIR', str(tmp_path))
    channel = f'sim-{uuid.uuid4().hex[:6]}'
    sim = start_sim(DEMO, channel, tmp_path)
    try:
        assert sim.stdout is not None
        lines = [sim.stdout.readline().strip() for _ in range(3)]
        assert [line.split()[1] for line in lines] == ['base_drive', 'arm_drive', 'lift_drive'], lines
        assert all(line.endswith(f'on local:{channel}') for line in lines), lines
        data = demo_data(channel)
        data['bus']['interface'] = 'local'
        data['simulation'] = {'enabled': False}
        node = BusNode(context=ros.context, parameter_overrides=[
            Parameter('config_yaml', value=yaml.safe_dump(data)), Parameter('auto_enable', value=True)])
        ros.add(node)
        try:
            # the drives are only in the other process: the bus process loads a configuration without them
            assert not node.master.config.simulation.enabled
            node.master.wait_until_operational(15.0)
            wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 15,
                     'auto_enable of every axis in the sim process')
            states: list[JointState] = []
            ros.node('sim_states').create_subscription(JointState, '/joint_states', states.append, 100)
            wait_for(lambda: states, 5, 'joint states')
            start = dict(zip(states[-1].name, states[-1].position))
            goal = start['base_joint'] + 0.3
            msg = JointTrajectory(joint_names=['base_joint'])
            msg.header.stamp = stamp_from_seconds(time.time() + 0.2)
            msg.points = [JointTrajectoryPoint(positions=[goal], velocities=[0.0],
                                               time_from_start=Duration(sec=0, nanosec=600_000_000))]
            ros.node('sim_traj').create_publisher(JointTrajectory, '/drive_bridge/joint_trajectory', 10).publish(msg)
            wait_for(lambda: abs(dict(zip(states[-1].name, states[-1].position))['base_joint'] - goal) < 1e-3,
                     10, 'base_joint at the goal, reported by the drive in the sim process')
            assert dict(zip(states[-1].name, states[-1].position))['lift_joint'] == pytest.approx(
                start['lift_joint'], abs=1e-3)
        finally:
            node.close()
        sim.send_signal(signal.SIGTERM)
        assert sim.wait(10) == 0, sim.stderr.read() if sim.stderr else ''
        assert not (tmp_path / channel).exists()  # the sockets are gone with their processes
    finally:
        sim.kill()


def test_sim_names_what_is_wrong(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(['sim', str(tmp_path / 'missing.yaml')]) == 2
    assert 'missing.yaml' in capsys.readouterr().err
    assert main(['sim', str(DEMO), '--interface', 'local', '--channel', 'a/b']) == 2
    assert 'without "/"' in capsys.readouterr().err
