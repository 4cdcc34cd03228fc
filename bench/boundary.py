"""The boundary between the node process and the bus process, under failure and under load.

- ``kill-node``: the node process (``bridge``) SIGKILLed while trajectories stream on 4 axes at
  4 ms: time from the kill to the quick-stop controlword on every axis (the bus process's
  reaction; goal 100 ms), and to every axis disabled or held. Beside it, the naive baseline: a
  bridge without a bus process dies whole, and its drives stop only when their heartbeat
  consumer misses the master (EMCY 0x8130): the same run kills the bus process and times that.
- ``kill-bus``: the bus process SIGKILLed: time to the node's ERROR on /diagnostics at a
  subscriber (goal 300 ms).
- ``quick-stop``: ``~/quick_stop`` answered while ten ``~/set_mode`` calls that never complete and
  20 clients calling ``~/sdo_read`` occupy the node (goal 50 ms), against the same call on an
  idle node in the same run.

The simulated drives run in this process on the ``local`` bus; a sniffer here timestamps the
frames (this process's clock for both the kill and the frames).

    .venv/bin/python -m bench boundary [--cases kill-node kill-bus quick-stop] [--runs 5]
"""
from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from pathlib import Path
from typing import Any

import yaml

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / 'config' / 'demo.yaml'
NS = '/drive_bridge'
CONTROLWORDS = (0x202, 0x203, 0x403, 0x204)  # the demo's four axes (node 3's second axis: RPDO3)
QUICK_STOP_MASK, QUICK_STOP = 0x0087, 0x0002
HEARTBEAT_ERROR = 0x8130
CASES = ('kill-node', 'kill-bus', 'quick-stop')


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float('nan')


def _figures(values: list[float]) -> str:
    if not values:
        return 'no figure'
    return (f'p50 {statistics.median(values) * 1e3:6.1f} ms  max {max(values) * 1e3:6.1f} ms  '
            f'({len(values)} runs)')


class Bus:
    """The demo's drives simulated on a local bus of their own (``drive-bridge sim``, a process
    of its own), and a sniffer on it here."""

    def __init__(self, work: Path, env: dict[str, str]) -> None:
        from drive_bridge.master.bus import open_bus
        self.channel = f'bd{uuid.uuid4().hex[:6]}'
        data = yaml.safe_load(DEMO.read_text())
        data['bus'] = {**data['bus'], 'interface': 'local', 'channel': self.channel}
        data['simulation'] = {'enabled': False}
        self.config = work / f'{self.channel}.yaml'
        self.config.write_text(yaml.safe_dump(data, sort_keys=False))
        tool = Path(sys.executable).parent / 'drive-bridge'
        self.sim = subprocess.Popen([str(tool), 'sim', str(DEMO), '--interface', 'local', '--channel', self.channel],
                                    stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env)
        assert self.sim.stdout is not None
        for _ in range(3):
            self.sim.stdout.readline()  # 'simulating ...' per node
        self.sniffer = open_bus('local', self.channel)
        self.frames: list[tuple[float, int, bytes]] = []
        self._stop = False
        self._thread = threading.Thread(target=self._sniff, daemon=True)
        self._thread.start()

    def _sniff(self) -> None:
        while not self._stop:
            msg = self.sniffer.recv(0.05)
            if msg is not None:
                self.frames.append((time.monotonic(), msg.arbitration_id, bytes(msg.data)))

    def first(self, since: float, match: Any) -> dict[int, float]:
        """COB-ID -> time of the first frame since ``since`` that ``match(cob_id, data)`` accepts."""
        found: dict[int, float] = {}
        for t, cob_id, data in list(self.frames):
            if t >= since and cob_id not in found and match(cob_id, data):
                found[cob_id] = t
        return found

    def close(self) -> None:
        self._stop = True
        self._thread.join(2)
        self.sniffer.shutdown()
        self.sim.terminate()
        try:
            self.sim.wait(10)
        except subprocess.TimeoutExpired:
            self.sim.kill()


def _bridge(config: Path, env: dict[str, str]) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, '-c', 'from drive_bridge.cli.bridge import bridge_main; bridge_main()',
                             str(config), '--ros-args', '-p', 'auto_enable:=true'],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)


def _bus_process(bridge: subprocess.Popen[bytes]) -> Any:
    import psutil
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        children = [p for p in psutil.Process(bridge.pid).children() if 'drive_bridge.busproc' in ' '.join(p.cmdline())]
        if children:
            return children[0]
        time.sleep(0.05)
    raise RuntimeError('no bus process')


def _enabled(node: Any) -> None:
    """Every axis enabled (auto_enable), seen on ~/axis_states."""
    from drive_bridge_interfaces.msg import AxisStates
    latest: list[Any] = []
    subscription = node.create_subscription(AxisStates, f'{NS}/axis_states', latest.append, 10)
    deadline = time.monotonic() + 60
    try:
        while not (latest and len(latest[-1].axes) == 4
                   and all(a.drive_state == a.DRIVE_ENABLED for a in latest[-1].axes)):
            if time.monotonic() > deadline:
                raise RuntimeError('the axes were not enabled')
            time.sleep(0.05)
    finally:
        node.destroy_subscription(subscription)


def _streaming(node: Any) -> None:
    """Every axis enabled, then a slow trajectory on all of them (from a ROS publisher here)."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    _enabled(node)
    publisher = node.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    while publisher.get_subscription_count() == 0:
        time.sleep(0.05)
    publisher.publish(JointTrajectory(
        joint_names=['base_joint', 'shoulder_joint', 'elbow_joint', 'lift_joint'],
        points=[JointTrajectoryPoint(positions=[0.8, 0.5, -0.5, 0.2], time_from_start=Duration(sec=8))]))
    time.sleep(1.0)
    node.destroy_publisher(publisher)


def _is_quick_stop(cob_id: int, data: bytes) -> bool:
    return cob_id in CONTROLWORDS and int.from_bytes(data[:2], 'little') & QUICK_STOP_MASK == QUICK_STOP


def _is_heartbeat_error(cob_id: int, data: bytes) -> bool:
    return 0x81 <= cob_id <= 0xFF and int.from_bytes(data[:2], 'little') == HEARTBEAT_ERROR


def kill_node(runs: int, work: Path, env: dict[str, str], node: Any) -> tuple[list[float], list[float]]:
    """(kill -> quick stop on every axis, kill of the bus process -> 0x8130 from every drive)."""
    stopped, heartbeat = [], []
    for run in range(runs):
        bus = Bus(work, env)
        bridge = _bridge(bus.config, env)
        try:
            _streaming(node)
            child = _bus_process(bridge)
            if run % 2 == 0:  # the bridge's reaction: the node dies, the bus process stops the axes
                killed = time.monotonic()
                os.kill(bridge.pid, signal.SIGKILL)
                match = _is_quick_stop
                wanted, into = set(CONTROLWORDS), stopped
            else:  # the naive baseline: the master dies with everything, the drives' consumer reacts
                killed = time.monotonic()
                child.kill()
                match = _is_heartbeat_error
                wanted, into = {0x82, 0x83, 0x84}, heartbeat
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline and set(bus.first(killed, match)) != wanted:
                time.sleep(0.01)
            found = bus.first(killed, match)
            if set(found) == wanted:
                into.append(max(found.values()) - killed)
            child.kill() if child.is_running() else None
        finally:
            if bridge.poll() is None:
                bridge.kill()
            bridge.wait(10)
            bus.close()
    return stopped, heartbeat


def kill_bus(runs: int, work: Path, env: dict[str, str], node: Any) -> list[float]:
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    figures = []
    for _ in range(runs):
        bus = Bus(work, env)
        bridge = _bridge(bus.config, env)
        errors: list[float] = []

        def on_diagnostics(array: DiagnosticArray, errors: list[float] = errors) -> None:
            if any(s.level == DiagnosticStatus.ERROR and 'bus process lost' in s.message for s in array.status):
                errors.append(time.monotonic())
        subscription = node.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 50)
        try:
            _streaming(node)
            child = _bus_process(bridge)
            killed = time.monotonic()
            child.kill()
            deadline = time.monotonic() + 5
            while not errors and time.monotonic() < deadline:
                time.sleep(0.005)
            if errors:
                figures.append(errors[0] - killed)
        finally:
            node.destroy_subscription(subscription)
            if bridge.poll() is None:
                bridge.kill()
            bridge.wait(10)
            bus.close()
    return figures


def quick_stop(runs: int, work: Path, env: dict[str, str], node: Any) -> tuple[list[float], list[float]]:
    """(quick stop latency on an idle node, the same under the long calls and the flood)."""
    from drive_bridge_interfaces.srv import AxisCommand, SdoRead, SetMode
    bus = Bus(work, env)
    bridge = _bridge(bus.config, env)
    idle: list[float] = []
    loaded: list[float] = []
    stop = threading.Event()
    try:
        _enabled(node)
        client = node.create_client(AxisCommand, f'{NS}/quick_stop')
        enable = node.create_client(AxisCommand, f'{NS}/enable')
        client.wait_for_service(timeout_sec=10)
        enable.wait_for_service(timeout_sec=10)

        def call(c: Any, request: Any) -> float:
            sent = time.monotonic()
            future = c.call_async(request)
            while not future.done():
                time.sleep(0.0005)
            return time.monotonic() - sent

        def measure(into: list[float], reenable: bool) -> None:
            for _ in range(runs):  # under load the enable would wait for a worker: the first stop is real
                if reenable:
                    call(enable, AxisCommand.Request(joints=['base_joint']))
                into.append(call(client, AxisCommand.Request(joints=['base_joint'])))
        measure(idle, True)
        call(enable, AxisCommand.Request(joints=['base_joint']))
        set_mode = node.create_client(SetMode, f'{NS}/set_mode')
        set_mode.wait_for_service(timeout_sec=10)
        for _ in range(10):
            set_mode.call_async(SetMode.Request(joints=['shoulder_joint'], mode='-100', timeout=30.0))

        def hammer() -> None:
            sdo = node.create_client(SdoRead, f'{NS}/sdo_read')
            sdo.wait_for_service(timeout_sec=10)
            while not stop.is_set():
                call(sdo, SdoRead.Request(node_id=2, index=0x6041, subindex=0))
        threads = [threading.Thread(target=hammer, daemon=True) for _ in range(20)]
        for thread in threads:
            thread.start()
        time.sleep(1.0)
        measure(loaded, False)
    finally:
        stop.set()
        if bridge.poll() is None:
            bridge.terminate()
        try:
            bridge.wait(15)
        except subprocess.TimeoutExpired:
            bridge.kill()
        bus.close()
    return idle, loaded


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog='python -m bench boundary', description=__doc__.split('\n\n')[0])
    parser.add_argument('--cases', nargs='+', choices=CASES, default=list(CASES))
    parser.add_argument('--runs', type=int, default=6)
    args = parser.parse_args(argv)
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import MultiThreadedExecutor
    with tempfile.TemporaryDirectory(prefix='boundary-') as tmp:
        work = Path(tmp)
        os.environ['DRIVE_BRIDGE_CAN_DIR'] = str(work / 'can')
        env = {**os.environ, 'PYTHONPATH': str(REPO)}
        context = Context()
        rclpy.init(context=context)
        node = rclpy.create_node('bench_boundary', context=context)
        executor = MultiThreadedExecutor(num_threads=4, context=context)
        executor.add_node(node)
        threading.Thread(target=executor.spin, daemon=True).start()
        try:
            if 'kill-node' in args.cases:
                stopped, heartbeat = kill_node(args.runs, work, env, node)
                print(f'kill-node  quick stop on every axis after the node died:  {_figures(stopped)}  (goal 100 ms)')
                print(f'           naive: 0x8130 from every drive after the master died: {_figures(heartbeat)}')
            if 'kill-bus' in args.cases:
                figures = _figures(kill_bus(args.runs, work, env, node))
                print(f'kill-bus   ERROR on /diagnostics after the bus process died: {figures}  (goal 300 ms)')
            if 'quick-stop' in args.cases:
                idle, loaded = quick_stop(max(args.runs, 10), work, env, node)
                print(f'quick-stop idle node: p99 {_pct(idle, 0.99) * 1e3:.1f} ms; ten hanging calls + 20 '
                      f'sdo_read clients: {_figures(loaded)}, p99 {_pct(loaded, 0.99) * 1e3:.1f} ms  (goal 50 ms)')
        finally:
            executor.shutdown()
            rclpy.shutdown(context=context)


if __name__ == '__main__':
    main(sys.argv[1:])
