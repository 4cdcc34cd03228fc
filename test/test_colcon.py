"""The repository builds in a colcon workspace with the exact command of docs/hardware.md.

The virtualenv stands in for ``source /opt/ros/jazzy/setup.bash``: it holds the same
ROS packages (from PyPI), and AMENT_PREFIX_PATH / CMAKE_PREFIX_PATH point at it.
"""
from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

# a colcon build (minutes) and the installed bridge, a ROS process
pytestmark = [pytest.mark.slow, pytest.mark.ros]
REPO = Path(__file__).resolve().parent.parent
VENV = Path(sys.prefix)


def readme_colcon_command() -> str:
    """The ``colcon build`` line of the workspace section of docs/hardware.md."""
    section = REPO.joinpath('docs', 'hardware.md').read_text().split('## Build in a colcon workspace', 1)[1]
    match = re.search(r'^(colcon build .*)$', section, re.MULTILINE)
    assert match, 'docs/hardware.md has no colcon build command in its workspace section'
    return match.group(1)


def ros_environment(domain_id: int) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(('AMENT', 'COLCON', 'PYTHON'))}
    env.update(
        PATH=f'{VENV / "bin"}{os.pathsep}{env["PATH"]}', VIRTUAL_ENV=str(VENV),
        AMENT_PREFIX_PATH=str(VENV), CMAKE_PREFIX_PATH=str(VENV),
        ROS_DOMAIN_ID=str(domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
    )
    return env


@pytest.fixture(scope='module')
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    ws = tmp_path_factory.mktemp('ws')
    src = ws / 'src' / 'drive_bridge'
    src.mkdir(parents=True)
    files = subprocess.run(['git', 'ls-files', '-co', '--exclude-standard', '-z'], cwd=REPO,
                           check=True, capture_output=True).stdout.decode().split('\0')
    for name in filter(None, files):
        if (REPO / name).is_file():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            (src / name).write_bytes((REPO / name).read_bytes())
    build = subprocess.run(['bash', '-c', readme_colcon_command()], cwd=ws, env=ros_environment(0),
                           capture_output=True, text=True, timeout=900)
    assert build.returncode == 0, f'colcon build failed:\n{build.stdout[-4000:]}\n{build.stderr[-4000:]}'
    return ws


def in_workspace(ws: Path, command: str, domain_id: int, **kwargs):
    script = f'source install/setup.bash && {command}'
    return subprocess.Popen(['bash', '-c', script], cwd=ws, env=ros_environment(domain_id),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True, **kwargs)


def test_both_packages_install_where_ros_tools_look(workspace: Path) -> None:
    install = workspace / 'install'
    for name in ('bridge', 'bridge_managed'):
        exe = install / 'drive_bridge' / 'lib' / 'drive_bridge' / name
        assert exe.is_file() and os.access(exe, os.X_OK), name
    share = install / 'drive_bridge' / 'share'
    assert (share / 'ament_index' / 'resource_index' / 'packages' / 'drive_bridge').is_file()
    assert (share / 'drive_bridge' / 'package.xml').is_file()
    assert (share / 'drive_bridge' / 'config' / 'demo.yaml').is_file()
    for name in ('launch/bridge.launch.py', 'launch/two_buses.launch.py', 'config/bridge_params.yaml',
                 'examples/moveit/moveit_controllers.yaml', 'examples/ros2_control/controllers.yaml',
                 'examples/ros2_control/ros2_control.urdf', 'examples/ros2_control/bridge_params.yaml'):
        assert (share / 'drive_bridge' / name).is_file(), name
    # tools/control_msgs stands in for ROS's control_msgs in the PyPI virtualenv only
    assert not (install / 'control_msgs').exists()
    iface_share = install / 'drive_bridge_interfaces' / 'share'
    assert (iface_share / 'ament_index' / 'resource_index' / 'packages' / 'drive_bridge_interfaces').is_file()
    assert (iface_share / 'drive_bridge_interfaces' / 'msg' / 'CanFrame.msg').is_file()


def test_interfaces_import_from_the_workspace(workspace: Path) -> None:
    code = ('import drive_bridge, drive_bridge_interfaces;'
            'from drive_bridge_interfaces.msg import CanFrame, Emcy, AxisState, SdoValue;'
            'from drive_bridge_interfaces.srv import SdoRead, SdoWrite, NmtCommand;'
            'from rclpy.type_support import check_for_type_support as c;'
            '[c(t) for t in (CanFrame, Emcy, AxisState, SdoValue, SdoRead, SdoWrite, NmtCommand)];'
            'print(drive_bridge.__file__); print(drive_bridge_interfaces.__file__)')
    proc = in_workspace(workspace, f'python -c {shlex.quote(code)}', 0)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0, out
    paths = out.strip().splitlines()[-2:]
    assert all(str(workspace / 'install') in p for p in paths), paths


def test_installed_executable_starts_and_stops_on_sigint(workspace: Path) -> None:
    domain_id = 150 + os.getpid() % 50
    proc = in_workspace(workspace, 'exec install/drive_bridge/lib/drive_bridge/bridge', domain_id)
    try:
        lines: list[str] = []
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not any('open' in line for line in lines):
            line = proc.stdout.readline()
            if not line:
                break
            lines.append(line)
        assert any('open' in line for line in lines), ''.join(lines)
        time.sleep(1.0)
        assert proc.poll() is None, 'bridge exited on its own:\n' + ''.join(lines) + proc.stdout.read()
        os.killpg(proc.pid, signal.SIGINT)
        out, _ = proc.communicate(timeout=20)
        assert proc.returncode == 0, ''.join(lines) + out
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
