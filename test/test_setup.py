"""The set-up commands: an idempotent, fast bootstrap and the demo bridge."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from drive_bridge_interfaces.msg import CanFrame

import ros2cli
from rostools import RosHarness, interrupt, output, spawn, wait_for
from shelltools import from_background_shell

REPO = Path(__file__).resolve().parent.parent


def test_second_bootstrap_is_a_fast_no_op() -> None:
    env = dict(os.environ, DRIVE_BRIDGE_VENV=sys.prefix)
    started = time.monotonic()
    run = subprocess.run(['bash', str(REPO / 'tools' / 'bootstrap.sh')], env=env,
                         capture_output=True, text=True, timeout=600)
    elapsed = time.monotonic() - started
    assert run.returncode == 0, run.stderr
    assert 'installing' not in run.stderr and 'building' not in run.stderr, run.stderr
    # a full bootstrap takes 1.5 min on a quiet machine; a no-op about 2 s (more on a busy one)
    assert elapsed < 30, f'bootstrap took {elapsed:.1f} s with everything in place'


@pytest.mark.parametrize('signum, started', [(signal.SIGINT, 'from a terminal'),
                                             (signal.SIGINT, 'by a background shell'),
                                             (signal.SIGTERM, 'by a background shell')],
                         ids=['SIGINT', 'SIGINT, inherited ignored', 'SIGTERM, SIGINT inherited ignored'])
def test_demo_bridge_publishes_until_the_signal(ros: RosHarness, tmp_path: Path, signum: int, started: str) -> None:
    """Stopped by the signal whatever it inherited: a background shell starts it with SIGINT ignored."""
    exe = [str(Path(sys.prefix) / 'bin' / 'bridge')]
    proc = spawn(from_background_shell(exe) if started == 'by a background shell' else exe, tmp_path / 'bridge.log',
                 env=dict(os.environ), stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        frames: list[CanFrame] = []
        ros.node('watcher').create_subscription(CanFrame, '/drive_bridge/can_frames', frames.append, 100)
        wait_for(lambda: len(frames) >= 20, 30, '20 frames from the demo bridge')
        assert all(f.header.frame_id == 'drive_bridge_demo' for f in frames)
        assert proc.poll() is None
        os.killpg(proc.pid, signum)
        proc.wait(timeout=30)
        out = output(proc)
        assert proc.returncode == 0, out  # a clean stop: motion stopped, the bus released
        assert 'Traceback' not in out, out
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)


def readme_section(heading: str) -> str:
    return (REPO / 'README.md').read_text().split(f'\n## {heading}\n', 1)[1].split('\n## ', 1)[0]


def code_blocks(section: str, language: str) -> list[str]:
    return re.findall(rf'```{language}\n(.*?)```', section, re.S)


def readme_python_example() -> str:
    return code_blocks(readme_section('The demo'), 'python')[0]


def _run_readme_example(ros: RosHarness, attempt: int, config: Path) -> tuple[bool, str]:
    """The demo bridge in its own process, the README's example against it: whether the joints
    arrived, and what the bridge printed."""
    from drive_bridge_interfaces.msg import AxisState, AxisStates
    from sensor_msgs.msg import JointState
    exe = Path(sys.prefix) / 'bin' / 'bridge'
    proc = spawn([str(exe), str(config), '--ros-args', '-p', 'auto_enable:=true'],
                 config.parent / f'bridge-{attempt}.log', env=dict(os.environ), start_new_session=True)
    arrived_at_goal = False
    try:
        states: list[JointState] = []
        axes: list[AxisStates] = []
        watcher = ros.node(f'example_watcher_{attempt}')
        watcher.create_subscription(JointState, '/joint_states', states.append, 100)
        watcher.create_subscription(AxisStates, '/drive_bridge/axis_states', axes.append, 100)
        try:  # generous: beside a benchmark the node (nice 10 by default) gets little of 2 cores
            wait_for(lambda: axes and len(axes[-1].axes) == 4 and all(
                a.state == AxisState.STATE_OPERATION_ENABLED for a in axes[-1].axes), 60, 'demo axes enabled')
        except AssertionError as exc:
            seen = [(a.joint_name, a.state) for a in axes[-1].axes] if axes else 'no axis states'
            raise AssertionError(f'{exc} (last seen: {seen}); the bridge printed: {output(proc)[-3000:]}') from None
        example = subprocess.run([sys.executable, '-c', readme_python_example()], env=dict(os.environ),
                                 capture_output=True, text=True, timeout=60)
        assert example.returncode == 0, example.stderr

        def arrived() -> bool:
            final = dict(zip(states[-1].name, states[-1].position))
            return abs(final.get('base_joint', 0.0) - 1.0) < 0.01 and abs(final.get('shoulder_joint', 0.0) - 0.5) < 0.01
        try:
            wait_for(arrived, 10, 'the example trajectory to reach base_joint 1.0, shoulder_joint 0.5')
            arrived_at_goal = True
        except AssertionError:
            pass
    finally:
        out = interrupt(proc)
    return arrived_at_goal, out


def test_readme_trajectory_example_moves_the_demo(ros: RosHarness, tmp_path: Path) -> None:
    # The shipped demo with heartbeat timeouts of 1 s instead of 300 ms (multiplier 10): in CI the
    # demo's process (bridge and simulated drives in one Python process) stalled 0.36-0.4 s as the
    # example's process joined, and the drives faulted by their heartbeat consumer
    # (docs/development.md, Tests; cause not found). Everything else is the demo as `make demo` runs it.
    data = yaml.safe_load((REPO / 'config' / 'demo.yaml').read_text())
    data.setdefault('options', {})['heartbeat_multiplier'] = 10
    config = tmp_path / 'demo.yaml'
    config.write_text(yaml.safe_dump(data, sort_keys=False))
    arrived, out = _run_readme_example(ros, 0, config)
    if not arrived and 'heartbeat lost' in out:
        # Seen in about one of four full-suite runs: the demo's process (bridge and simulated drives
        # in one Python process) stalls ~0.4 s while another ROS process joins, and the drives
        # fault by their heartbeat consumer (300 ms) before the trajectory comes. That is the
        # drives' safety reaction working; the README example itself is tried once more.
        print('first attempt: the demo stalled and its drives faulted by heartbeat; again')
        arrived, out = _run_readme_example(ros, 1, config)
    assert arrived, f'the README example did not move the demo; the bridge printed: {out[-2000:]}'


@pytest.mark.slow
def test_readme_your_drive_in_ten_lines(tmp_path: Path) -> None:
    """The README's "your drive in ten lines" as a new user runs it: its YAML as my_bus.yaml,
    its two commands (drive-bridge sim, then the bridge, over the local transport), its Python
    client (enable, a trajectory to 1 rad, an SDO read), then its ros2 lines."""
    section = readme_section('Your drive in ten lines')
    # with heartbeat timeouts of 1 s instead of 300 ms (multiplier 10), as the demo test above: on a
    # loaded machine (load 10 on 2 cores) the drive faulted by its heartbeat consumer (EMCY 0x8130)
    data = yaml.safe_load(code_blocks(section, 'yaml')[0])
    data.setdefault('options', {})['heartbeat_multiplier'] = 10
    (tmp_path / 'my_bus.yaml').write_text(yaml.safe_dump(data, sort_keys=False))
    commands = [line.split('#')[0].strip().rstrip('&').strip() for line in code_blocks(section, 'bash')[0].splitlines()]
    assert [c.split()[0] for c in commands] == ['.venv/bin/drive-bridge', '.venv/bin/bridge']
    env = dict(os.environ, DRIVE_BRIDGE_CAN_DIR=str(tmp_path))  # the local bus of this test only
    procs = []
    try:
        for command in commands:
            words = command.split()
            words[0] = str(Path(sys.prefix) / 'bin' / Path(words[0]).name)
            procs.append(spawn(words, tmp_path / f'{Path(words[0]).name}.log', cwd=tmp_path, env=env,
                               start_new_session=True))
        session = ros2cli.Session()
        try:
            # the user starts the client once the bridge said "node 2 (my_drive) booted and operational"
            wait_for(lambda: session.echo('/drive_bridge/axis_states', 1)[0].axes[0].nmt_state == 'OPERATIONAL',
                     60, 'node 2 operational')
            client = subprocess.run([sys.executable, '-c', code_blocks(section, 'python')[0]], cwd=tmp_path,
                                    env=env, capture_output=True, text=True, timeout=120)
            assert client.returncode == 0, client.stderr
            printed = client.stdout.splitlines()
            assert printed[0] == 'enable: done for my_joint', printed
            position = float(printed[1].split(':')[1].strip(' }'))
            assert abs(position - 1.0) < 0.01, printed
            assert printed[2].startswith('node 2 0x6064:00 = 1043'), printed  # 1 rad x 10 x 65536 / 2 pi = 104,304
            for line in code_blocks(section, 'bash')[1].splitlines():
                if line.startswith('ros2 '):
                    answer = ros2cli.run(ros2cli.split_command(line), session)
                    assert getattr(answer, 'success', True), f'{line}: {answer}'
        finally:
            session.close()
    finally:
        for proc in reversed(procs):  # the bridge first: it stops the axis while the drive still runs
            interrupt(proc)
