"""The markers ``ros``, ``sim`` and ``slow`` and what ``make test-fast`` runs: the core's tests
without rclpy, chosen without importing it."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from markertools import module_kinds

HERE = Path(__file__).resolve().parent


def test_a_module_is_marked_by_what_it_uses() -> None:
    # rclpy, drive_bridge.ros; bridgetools runs the simulated drives in the test's process
    assert module_kinds(HERE / 'test_ros_node.py') == {'ros', 'sim'}
    # faulttools.demo_bridge imports ROS inside; bridgetools (its fresh snapshots) the simulator
    assert module_kinds(HERE / 'test_faults_messages.py') == {'ros', 'sim'}
    assert module_kinds(HERE / 'test_faults_flood.py') == {'sim'}  # bustools.running starts simulated drives
    assert module_kinds(HERE / 'test_bag_passive.py') == set()  # bustools.unique_channel uses no simulator
    assert module_kinds(HERE / 'test_config_load.py') == set()


def test_the_core_tests_are_chosen_and_collected_without_rclpy() -> None:
    script = ('import json, sys, pytest\n'
              'code = pytest.main(["-q", "--collect-only", "-p", "no:cacheprovider", "-m", "not ros", sys.argv[1]])\n'
              'print(json.dumps([code, sorted(m for m in sys.modules if m.split(".")[0] in '
              '("rclpy", "sensor_msgs", "drive_bridge_interfaces") or m.startswith("drive_bridge.ros"))]))\n')
    done = subprocess.run([sys.executable, '-c', script, str(HERE)], capture_output=True, text=True, timeout=300,
                          cwd=HERE.parent, check=False)
    code, ros_modules = json.loads(done.stdout.strip().splitlines()[-1])
    assert code == 0, done.stdout[-2000:]
    assert ros_modules == [], ros_modules
    assert 'test_stop_signals.py' in done.stdout and 'test_ros_node.py' not in done.stdout
