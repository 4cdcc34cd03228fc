"""The bridge as users run it, against a naive canopen + rclpy bridge, on the same drives.

Three processes per case, over the package's ``local`` CAN transport: the simulated drives
(``drive-bridge sim``), the bridge (rclpy ``BusNode``: ``/joint_states`` every cycle,
``/diagnostics``, a trajectory streaming on every axis from the subscriber's process), and a
ROS subscriber of ``/joint_states``. The naive bridge, in the same run and on fresh drives
with the same PDO maps, is what the canopen and rclpy documentation lead to: canopen's
``network.sync.start`` (python-can's thread task), ``RemoteNode`` TPDO callbacks decoding
with ``PdoVariable.raw``, and an rclpy timer at the SYNC period that writes the set-points
(the same motion, computed in place: it has no trajectory handling to pay for) and
publishes the joint states. The rt variant is the bridge with ``master.realtime_priority``
(SCHED_FIFO for its cycle thread), as docs/hardware.md tells users on a robot.
The core variant (bench/ros_cycle_core.py), also in the same
run, is the bridge's core alone in the bridge process, without rclpy: Master and
TrajectoryExecutor streaming the same motion and reading the joint feedback each cycle,
publishing nothing (no subscriber): what moving the cycle and the CAN I/O into a process of
their own could gain at most.

Per case, measured in the bridge process over the window (frames seen by its bus tap):
SYNC interval at send (p50/p99/max), skipped cycles (grid points without a SYNC), set-points
on time (every node's set-point RPDO sent after SYNC n-1 and before SYNC n) and how long
before its SYNC the last one went out; at the subscriber: TPDO reception (the JointState
stamp, taken from the received TPDO) -> message received (p50/p99); the bridge process's
CPU (psutil, % of one core); the bus load of the PDO maps (budget, worst-case stuffing);
rows over 70 % of 1 Mbit/s are marked ``!`` (run with bus.allow_overload). The machine's floor
for these figures, meanwhile: a bare sleep loop on the period grid in a process of its own, with
the bridge's skip rule (interval p99 between its wake-ups, as the SYNC p99, and skipped share).

    .venv/bin/python -m bench ros_cycle [--quick] [--axes 1 2 4 6 8] [--periods 1 2 4 10] [--seconds 10]
        [--variants bridge rt naive core] [--maps default|compact]
"""
from __future__ import annotations

import argparse
import gc
import json
import math
import os
import random
import shutil
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

from bench.floods import FLOODS, flood_role  # noqa: E402
from bench.ros_cycle_common import WARMUP, Window, motion, trajectory_points

REPO = Path(__file__).resolve().parent.parent
TOOL = Path(sys.executable).parent / 'drive-bridge'
# the RPDO carrying the set-point (target position): RPDO 2 of the generic 402 family's default
# maps (target position + velocity), RPDO 1 of the compact maps (controlword + target position)
RPDO_SETPOINT = {'default': 0x300, 'compact': 0x200}
MAPS = tuple(RPDO_SETPOINT)
VARIANTS = ('bridge', 'rt', 'naive', 'core', 'single')
# 'single': the bridge of another checkout (--baseline, e.g. before the bus process: one process)
BASELINE: dict[str, Path] = {}
REALTIME_PRIORITY = 50  # the rt variant: the bridge with master.realtime_priority (SCHED_FIFO)


def _entries(*indices: int) -> list[dict[str, int]]:
    return [{'index': index, 'sub_index': 0} for index in indices]


# One RPDO and one TPDO per axis and cycle: what a CSP axis needs each SYNC (the statusword and
# the mode display go on change, refreshed every 100 ms; the mode is written by SDO).
COMPACT_PDOS = {
    'rpdo': {1: {'transmission': 1, 'mapping': _entries(0x6040, 0x607A)}},
    'tpdo': {1: {'transmission': 1, 'mapping': _entries(0x6064, 0x606C)},
             2: {'transmission': 255, 'event_timer': 100, 'mapping': _entries(0x6041, 0x6061)}},
}
SYNC_ID = 0x080


def bus_data(axes: int, period_ms: float, channel: str, maps: str = 'default',
             realtime: bool = False) -> dict[str, Any]:
    pdos = COMPACT_PDOS if maps == 'compact' else {}
    return {
        'bus': {'interface': 'local', 'channel': channel, 'bitrate': 1_000_000, 'allow_overload': True},
        'master': {'node_id': 127, 'sync_period': round(period_ms * 1000), 'heartbeat_producer': 100,
                   **({'realtime_priority': REALTIME_PRIORITY} if realtime else {})},
        'nodes': {f'drive{i}': {'node_id': i, 'family': 'generic_402', 'heartbeat_producer': 100, **pdos,
                                'axes': [{'joint': f'j{i}', 'mode': 'csp',
                                          'scaling': {'counts_per_revolution': 65536, 'rated_torque': 1.0},
                                          'limits': {'max_velocity': 5.0}}]}
                  for i in range(1, axes + 1)},
    }


def _map_with(table: Any, index: int) -> Any:
    """The PDO map of canopen's ``table`` (RemoteNode.rpdo/tpdo) that carries ``index`` (or None)."""
    return next((m for m in table.map.values() if m.enabled and any(v.index == index for v in m.map)), None)


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float('nan')


# --- the bridge process -------------------------------------------------------------------------

def bridge_role(config_path: str, variant: str, out: str, seconds: float) -> None:
    if variant == 'core':  # before rclpy is imported: the core variant runs without it
        from bench.ros_cycle_core import core_role
        return core_role(config_path, seconds, out)
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    window = Window()
    ready = threading.Event()
    rclpy.init(args=['bench_bridge', '--ros-args', '-p', 'auto_enable:=true'])
    if variant in ('bridge', 'rt'):
        from drive_bridge.cia402.statemachine import State
        from drive_bridge.ros.node import BusNode
        node: Any = BusNode(config_path)
        from drive_bridge.ros.main import lower_priority
        lower_priority(int(os.environ.get('BENCH_NODE_NICE', node.params.node_nice)))  # as ros.main.run does
        window.capture = lambda path: node.master.capture(path)  # frames seen by the bus process's tap
        window.processes.append(node.master.pid)

        def wait_enabled() -> None:
            node.master.wait_until_operational(30)
            deadline = time.monotonic() + 30
            while not all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()):
                if time.monotonic() > deadline:
                    print('not all axes enabled', file=sys.stderr, flush=True)
                    os._exit(3)
                time.sleep(0.05)
            ready.set()
        threading.Thread(target=wait_enabled, daemon=True).start()
        close = node.close
    else:
        node = NaiveBridge(config_path, window, ready)
        close = node.close
    gc.collect()
    gc.freeze()  # as drive_bridge.ros.main.run does
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    control = threading.Thread(target=window.run, args=(ready,), daemon=True)
    control.start()
    spin = threading.Thread(target=lambda: _spin(executor, ExternalShutdownException), daemon=True)
    spin.start()
    control.join()
    sync_stats = None
    streaming = None
    if variant in ('bridge', 'rt'):
        streaming = [h.state for h in node.trajectories.active()]
        s = node.master.snapshot().sync
        if s is not None:
            sync_stats = {'skipped': s.skipped, 'cycles': s.cycles}
    Path(out).write_text(json.dumps({'frames': window.frames, 'cpu': window.cpu[0], 'own': sync_stats,
                                     'streaming': streaming}))
    close()
    executor.shutdown(timeout_sec=1)
    os._exit(0)  # rclpy teardown in a benchmark child is not measured


def _spin(executor: Any, shutdown_error: type[BaseException]) -> None:
    try:
        executor.spin()
    except shutdown_error:
        pass


def _make_naive(base: type) -> type:
    """The naive bridge class (defined late: it subclasses rclpy's Node, imported only in the child)."""
    import canopen
    from sensor_msgs.msg import JointState

    from drive_bridge.config import load_bus_config
    from drive_bridge.master.bus import FrameTap, TappedBus, open_bus

    class Naive(base):  # type: ignore[misc, valid-type]
        def __init__(self, config_path: str, window: Window, ready: threading.Event) -> None:
            super().__init__('drive_bridge')
            self.config = load_bus_config(config_path)
            tap = FrameTap()
            tap.add_listener(window)
            bus = self.config.bus
            self.network = canopen.Network(TappedBus(open_bus(bus.interface, bus.channel, bus.bitrate), tap))
            self.network.connect()
            self.axes = []
            for k, cfg in enumerate(self.config.nodes):
                remote = canopen.RemoteNode(cfg.node_id, cfg.od)
                self.network.add_node(remote)
                remote.nmt.state = 'PRE-OPERATIONAL'
                for table, pdos in ((remote.rpdo, cfg.rpdo), (remote.tpdo, cfg.tpdo)):
                    table.read(from_od=True)
                    wanted = {pdo.number: pdo for pdo in pdos}
                    for number, pdo_map in table.map.items():
                        pdo = wanted.get(number)
                        if pdo is None:  # the same maps as the bridge's: nothing else enabled
                            if pdo_map.enabled:
                                pdo_map.enabled = False
                                pdo_map.save()
                            continue
                        pdo_map.clear()
                        for entry in pdo.mapping:
                            pdo_map.add_variable(entry.index, entry.subindex, entry.bits)
                        pdo_map.cob_id, pdo_map.trans_type, pdo_map.enabled = pdo.cob_id, pdo.transmission, True
                        pdo_map.save()
                axis = {'node': remote, 'k': k, 'scaling': cfg.axes[0].scaling, 'name': cfg.axes[0].joint,
                        'sw': 0, 'pos': None, 'stamp': 0.0, 'start': None}
                _map_with(remote.tpdo, 0x6041).add_callback(lambda m, a=axis: a.update(sw=m[0x6041].raw))
                _map_with(remote.tpdo, 0x6064).add_callback(
                    lambda m, a=axis: a.update(pos=m[0x6064].raw, stamp=m.timestamp))
                axis['control'], axis['target'] = _map_with(remote.rpdo, 0x6040), _map_with(remote.rpdo, 0x607A)
                axis['mode'] = _map_with(remote.rpdo, 0x6060)
                if axis['mode'] is None:
                    remote.sdo[0x6060].raw = 8  # csp, once: no RPDO carries the mode
                self.axes.append(axis)
            for axis in self.axes:
                axis['node'].nmt.state = 'OPERATIONAL'
            period = self.config.master.sync_period
            self.network.sync.start(period)
            self.publisher = self.create_publisher(JointState, '/joint_states', 10)
            self.t0: float | None = None
            self.ready = ready
            self.timer = self.create_timer(period, self.on_timer)

        def on_timer(self) -> None:
            now = time.time()
            msg = JointState()
            enabled = 0
            for axis in self.axes:
                sw = axis['sw']
                if axis['pos'] is None:
                    continue
                state = sw & 0x6F
                cw = 0x06 if state in (0x40, 0x60) or sw & 0x4F == 0x40 else 0x07 if state == 0x21 else 0x0F
                if sw & 0x08:
                    cw = 0x80
                if state == 0x27:
                    enabled += 1
                if axis['start'] is None or state != 0x27:
                    axis['start'] = axis['pos']
                    target = axis['pos']
                else:
                    t = now - self.t0 if self.t0 is not None else 0.0
                    target = axis['start'] + axis['scaling'].position_to_device(motion(t, axis['k']))
                axis['control'][0x6040].raw = cw
                if axis['mode'] is not None:
                    axis['mode'][0x6060].raw = 8
                axis['target'][0x607A].raw = int(target)
                for pdo_map in {id(m): m for m in (axis['control'], axis['mode'], axis['target']) if m}.values():
                    pdo_map.transmit()
                msg.name.append(axis['name'])
                msg.position.append(axis['scaling'].position_to_si(axis['pos']))
            if enabled == len(self.axes) and self.t0 is None:
                self.t0 = now
                self.ready.set()
            stamps = [a['stamp'] for a in self.axes if a['stamp']]
            if msg.name and stamps:
                newest = max(stamps)
                msg.header.stamp.sec = int(newest)
                msg.header.stamp.nanosec = int((newest % 1) * 1e9)
                self.publisher.publish(msg)

        def close(self) -> None:
            self.network.sync.stop()
            self.network.disconnect()

    return Naive


def NaiveBridge(config_path: str, window: Window, ready: threading.Event) -> Any:  # noqa: N802 (a factory)
    from rclpy.node import Node
    return _make_naive(Node)(config_path, window, ready)


# --- the subscriber process ---------------------------------------------------------------------

def subscriber_role(joints: int, out: str, stream: bool, seconds: float) -> None:
    import rclpy
    from builtin_interfaces.msg import Duration
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    rclpy.init()
    node = rclpy.create_node('bench_subscriber')
    received: list[tuple[float, float]] = []
    latest: dict[str, float] = {}

    def on_state(msg: JointState) -> None:
        received.append((time.time(), msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9))
        latest.update(zip(msg.name, msg.position))
    node.create_subscription(JointState, '/joint_states', on_state, 100)
    publisher = node.create_publisher(JointTrajectory, '/drive_bridge/joint_trajectory', 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()
    while len(latest) < joints:
        time.sleep(0.05)
    sys.stdin.readline()  # 'go': the bridge's axes are all enabled (a trajectory before that is refused)
    if stream:  # one trajectory on every axis from where they are, outlasting the window
        names = sorted(latest, key=lambda n: int(n[1:]))
        msg = JointTrajectory(joint_names=names)  # stamp zero: it starts when the bridge takes it
        # (a stamp the message's delivery overtakes would be refused: its start in the past, the
        # lead-in to the first future point faster than the joint's limit)
        for t, positions, velocities in trajectory_points([latest[j] for j in names], seconds + WARMUP):
            msg.points.append(JointTrajectoryPoint(
                positions=positions, velocities=velocities,
                time_from_start=Duration(sec=int(t), nanosec=int(round((t % 1) * 1e9)) % 1_000_000_000)))
        while publisher.get_subscription_count() == 0:
            time.sleep(0.05)
        publisher.publish(msg)
    print('streaming', flush=True)
    sys.stdin.readline()
    Path(out).write_text(json.dumps(received))
    os._exit(0)


# --- the machine probe -------------------------------------------------------------------------

def probe_role(period: float, seconds: float, out: str) -> None:
    """A bare sleep loop on the period grid, the bridge's skip rule: what the machine alone costs."""
    from bench.floor import sleep_loop
    Path(out).write_text(json.dumps(sleep_loop(period, seconds)))


# --- the orchestrator ---------------------------------------------------------------------------

def _popen(args: list[str], env: dict[str, str], log: Path, cwd: Path = REPO) -> subprocess.Popen[str]:
    with log.open('a') as stderr:  # the children's logs: read when a case fails
        return subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=stderr, text=True,
                                env=env, cwd=cwd)


def _expect(process: subprocess.Popen[str], word: str, what: str, timeout: float = 60.0) -> None:
    assert process.stdout is not None
    result: list[str] = []
    reader = threading.Thread(target=lambda: result.append(process.stdout.readline()), daemon=True)  # type: ignore[union-attr]
    reader.start()
    reader.join(timeout)
    if not result or word not in result[0]:
        raise RuntimeError(f'{what} did not say {word!r} within {timeout:.0f} s (got {result!r})')


def run_case(axes: int, period_ms: float, variant: str, seconds: float, work: Path, env: dict[str, str],
             maps: str = 'default', flood: str | None = None) -> dict:
    channel = f'b{uuid.uuid4().hex[:6]}'
    config = work / f'{channel}.yaml'
    config.write_text(yaml.safe_dump(bus_data(axes, period_ms, channel, maps, realtime=variant == 'rt')))
    me = [sys.executable, '-m', 'bench.ros_cycle']
    bridge_me, bridge_env, bridge_variant = me, env, variant
    if variant == 'single':  # the other checkout's bridge, with its own venv and code
        base = BASELINE['dir']
        bridge_me = [str(base / '.venv' / 'bin' / 'python'), '-m', 'bench.ros_cycle']
        # not this venv's libraries: the other venv's interpreter finds its own (ROS wheels' bootstrapper)
        bridge_env = {k: v for k, v in env.items()
                      if k not in ('LD_LIBRARY_PATH', 'VIRTUAL_ENV', '_ROS_WHEELS_BOOTSTRAP_COMPLETE')}
        bridge_env, bridge_variant = {**bridge_env, 'PYTHONPATH': str(base)}, 'bridge'
    log = work / f'{channel}.log'
    # rt: the simulated drives at the bridge's cycle priority too, else its SCHED_FIFO cycle starves them
    realtime = ['chrt', '-f', str(REALTIME_PRIORITY)] if variant == 'rt' and shutil.which('chrt') else []
    sim = _popen([*realtime, str(TOOL), 'sim', str(config)], env, log)
    processes = [sim]
    try:
        for _ in range(axes):
            _expect(sim, 'simulating', 'drive-bridge sim')
        bridge = _popen([*bridge_me, '--role', 'bridge', '--variant', bridge_variant, '--config', str(config),
                         '--seconds', str(seconds), '--out', str(work / f'{channel}.bridge.json')], bridge_env, log,
                        cwd=BASELINE['dir'] if variant == 'single' else REPO)
        processes.append(bridge)
        sub = None
        if variant != 'core':  # the core variant publishes nothing: no subscriber
            stream = ['--stream'] if variant in ('bridge', 'rt', 'single') else []
            sub = _popen([*me, '--role', 'subscriber', '--joints', str(axes), '--seconds', str(seconds),
                          '--out', str(work / f'{channel}.sub.json'), *stream], env, log)
            processes.append(sub)
        _expect(bridge, 'ready', f'{variant} bridge', 90)
        if sub is not None:
            assert sub.stdin is not None
            sub.stdin.write('go\n')
            sub.stdin.flush()
            _expect(sub, 'streaming', 'subscriber', 60)
        if flood is not None:  # beside every variant alike: its own CPU counts on both sides
            flooder = _popen([*me, '--role', 'flood', '--kind', flood, '--joints', str(axes),
                              '--seconds', str(seconds + WARMUP + 5)], env, log)
            processes.append(flooder)
            _expect(flooder, 'flooding', f'{flood} flood', 60)
        time.sleep(WARMUP + 0.3)
        assert bridge.stdin is not None
        bridge.stdin.write('start\n')
        bridge.stdin.flush()
        opened = time.time()
        probe = _popen([*me, '--role', 'probe', '--period', str(period_ms / 1000), '--seconds', str(seconds),
                        '--out', str(work / f'{channel}.probe.json')], env, log)
        processes.append(probe)
        time.sleep(seconds)
        probe.wait(30)
        bridge.stdin.write('stop\n')
        bridge.stdin.flush()
        closed = time.time()
        bridge.wait(30)
        states: list[list[float]] = []
        if sub is not None:
            assert sub.stdin is not None
            sub.stdin.write('stop\n')
            sub.stdin.flush()
            sub.wait(30)
            states = json.loads((work / f'{channel}.sub.json').read_text())
        data = json.loads((work / f'{channel}.bridge.json').read_text())
        data['probe'] = json.loads((work / f'{channel}.probe.json').read_text())
        if variant != 'naive' and 'active' not in (data.get('streaming') or []):
            raise RuntimeError(f'the {variant} bridge was not streaming a trajectory at the window\'s end '
                               f'(trajectories {data.get("streaming")})')
    except Exception as exc:
        tail = log.read_text(errors='replace').strip().splitlines()[-3:]
        raise RuntimeError(f'{exc}; log: {" | ".join(tail)}') from None
    finally:
        for process in processes:
            if process.poll() is None:
                process.terminate()
        for process in processes:
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
    return analyse(data, [s for s in states if opened <= s[0] <= closed], axes, period_ms / 1000,
                   RPDO_SETPOINT[maps])


def analyse(data: dict, states: list[list[float]], axes: int, period: float,
            setpoint_cob: int = RPDO_SETPOINT['default']) -> dict:
    frames = data['frames']
    syncs = [t for t, can_id, sent in frames if sent and can_id == SYNC_ID]
    intervals = [b - a for a, b in zip(syncs, syncs[1:])]
    skipped = sum(max(0, round(iv / period) - 1) for iv in intervals)
    setpoints = [(t, can_id) for t, can_id, sent in frames if sent and setpoint_cob < can_id <= setpoint_cob + 127]
    on_time = 0
    leads: list[float] = []
    i = 0
    for previous, sync in zip(syncs, syncs[1:]):
        while i < len(setpoints) and setpoints[i][0] <= previous:
            i += 1
        j = i
        nodes: set[int] = set()
        last = 0.0
        while j < len(setpoints) and setpoints[j][0] < sync:
            nodes.add(setpoints[j][1])
            last = setpoints[j][0]
            j += 1
        if len(nodes) == axes:
            on_time += 1
            leads.append(sync - last)
    latency = [recv - stamp for recv, stamp in states if stamp > 0]
    probe = data.get('probe')
    emcy = sum(1 for _t, can_id, sent in frames if not sent and 0x81 <= can_id <= 0xFF)
    return {'sync_p50': statistics.median(intervals) if intervals else float('nan'),
            'sync_p99': _pct(intervals, 0.99), 'sync_max': max(intervals, default=float('nan')),
            'cycles': len(intervals), 'skipped': skipped,
            'on_time': on_time / len(intervals) if intervals else float('nan'),
            'lead_p50': statistics.median(leads) if leads else float('nan'),
            'js_p50': statistics.median(latency) if latency else float('nan'),
            'js_p99': _pct(latency, 0.99), 'js_rate': len(states), 'cpu': data['cpu'], 'emcy': emcy,
            'idle_skip': probe['skipped'] / (probe['skipped'] + probe['cycles']) if probe else float('nan'),
            'idle_p99': probe.get('interval_p99', float('nan')) if probe else float('nan')}


def _ratio(naive: float, bridge: float, lower_is_better: bool = True) -> str:
    if not (math.isfinite(naive) and math.isfinite(bridge)):
        return '-'
    if bridge == 0:
        return '∞' if naive > 0 else '1'
    return f'{naive / bridge:.1f}×' if lower_is_better else f'{bridge / naive:.1f}×' if naive else '∞'


HEADER = (f'{"axes":>4} {"ms":>3} {"load":>5} {"":6} {"SYNC p50":>8} {"p99":>6} {"max":>6} {"skipped":>13} '
          f'{"on time":>7} {"lead":>5} {"js p50":>6} {"js p99":>6} {"CPU":>5} {"idle p99":>8} {"idle skip":>9}')


def _ms(value: float, width: int) -> str:
    """Seconds as ms in ``width``; '-' for a figure the variant does not have."""
    return f'{value * 1e3:{width}.2f}' if math.isfinite(value) else f'{"-":>{width}}'


def row(axes: int, period_ms: float, load: float, variant: str, r: dict) -> str:
    mark = '!' if load > 0.7 else ' '
    return (f'{axes:4d} {period_ms:3g} {load:4.0%}{mark} {variant:6} {_ms(r["sync_p50"], 8)} '
            f'{_ms(r["sync_p99"], 6)} {_ms(r["sync_max"], 6)} {r["skipped"]:6d}/{r["cycles"] + r["skipped"]:<6d} '
            f'{r["on_time"]:7.1%} {_ms(r["lead_p50"], 5)} {_ms(r["js_p50"], 6)} {_ms(r["js_p99"], 6)} '
            f'{r["cpu"]:5.0%} {_ms(r["idle_p99"], 8)} {r["idle_skip"]:9.1%}')


def ratio_row(bridge: dict, naive: dict, period: float, label: str = 'bridge') -> str:
    """naive / bridge (or rt) under the figure's column (jitter = |SYNC p99 - period|, late = 1 - on time)."""
    jitter = lambda r: abs(r['sync_p99'] - period)  # noqa: E731
    late = lambda r: 1 - r['on_time']  # noqa: E731
    name = 'ratio' if label == 'bridge' else 'ratioR'
    return (f'{"":14} {name:6} {"":8} {_ratio(jitter(naive), jitter(bridge)):>6} {"":6} '
            f'{_ratio(naive["skipped"], bridge["skipped"]):>13} {_ratio(late(naive), late(bridge)):>7} {"":5} '
            f'{"":6} {_ratio(naive["js_p99"], bridge["js_p99"]):>6} {_ratio(naive["cpu"], bridge["cpu"]):>5}')


def goal_line(results: dict[str, dict]) -> str:
    """The bus process's goals as ratios in this run: bridge skipped / core skipped (<= 1.5), rt
    skipped share - the bare loop's (<= 0.5 points), CPU and js p99 against the single process."""
    def share(r: dict) -> float:
        return r['skipped'] / max(1, r['skipped'] + r['cycles'])
    parts = []
    bridge, core, rt, single = (results.get(v) for v in ('bridge', 'core', 'rt', 'single'))
    if bridge and core:
        parts.append(f'skipped bridge/core {_ratio(bridge["skipped"], core["skipped"])}'.replace('×', '') + ' (<= 1.5)')
    if rt:
        parts.append(f'rt - floor {100 * (share(rt) - rt["idle_skip"]):+.1f} points (<= 0.5)')
    if bridge and single:
        parts.append(f'CPU bridge/single {bridge["cpu"] / single["cpu"]:.2f} (<= 1.3)' if single['cpu'] else '')
        parts.append(f'js p99 bridge {bridge["js_p99"] * 1e3:.2f} ms, single {single["js_p99"] * 1e3:.2f} ms')
        parts.append(f'skipped bridge/single {_ratio(bridge["skipped"], single["skipped"])}'.replace('×', ''))
    return '; '.join(p for p in parts if p)


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog='python -m bench ros_cycle', description=__doc__.split('\n\n')[0])
    parser.add_argument('--role', choices=['bridge', 'subscriber', 'probe', 'flood'], help=argparse.SUPPRESS)
    parser.add_argument('--kind', help=argparse.SUPPRESS)
    parser.add_argument('--period', type=float, default=0.0, help=argparse.SUPPRESS)
    parser.add_argument('--variant', default='bridge', help=argparse.SUPPRESS)
    parser.add_argument('--config', help=argparse.SUPPRESS)
    parser.add_argument('--out', help=argparse.SUPPRESS)
    parser.add_argument('--joints', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--stream', action='store_true', help=argparse.SUPPRESS)
    parser.add_argument('--quick', action='store_true', help='a check: 1 and 4 axes at 4 ms, 3 s each')
    parser.add_argument('--axes', type=int, nargs='+', default=[1, 2, 4, 6, 8])
    parser.add_argument('--periods', type=float, nargs='+', default=[1, 2, 4, 10], help='SYNC periods in ms')
    parser.add_argument('--seconds', type=float, default=10.0, help='measurement window per case (default 10)')
    parser.add_argument('--variants', nargs='+', default=None, choices=VARIANTS,
                        help='default: bridge rt naive core, and single with --baseline')
    parser.add_argument('--baseline', type=Path,
                        help="another checkout (bootstrapped) whose bridge runs as the variant 'single', e.g. the "
                             'last commit before the bus process, for the same figures of both in one run')
    parser.add_argument('--maps', choices=MAPS, default='default',
                        help="PDO maps: the family's default (2 RPDOs + 2 TPDOs per axis) or compact (1 + 1 "
                             'per cycle, the statusword on change)')
    parser.add_argument('--floods', nargs='*', choices=FLOODS, default=None,
                        help='instead of the table: each flood (default all) beside the bridge and beside core, '
                             'with the same case without flood, at the first of --axes/--periods (default 4 at 4 ms)')
    args = parser.parse_args(argv)
    if args.role == 'flood':
        return flood_role(args.kind, args.joints, args.seconds)
    if args.role == 'bridge':
        return bridge_role(args.config, args.variant, args.out, args.seconds)
    if args.role == 'subscriber':
        return subscriber_role(args.joints, args.out, args.stream, args.seconds)
    if args.role == 'probe':
        return probe_role(args.period, args.seconds, args.out)
    if args.variants is None:
        args.variants = [v for v in VARIANTS if v != 'single' or args.baseline]
    if args.baseline is not None:
        BASELINE['dir'] = args.baseline.resolve()
    elif 'single' in args.variants:
        parser.error('the variant single needs --baseline DIR')
    if args.quick:
        args.axes, args.periods, args.seconds = [1, 4], [4], 3.0
    if args.floods is not None and '--axes' not in argv:
        args.axes, args.periods = [4], [4]
    from drive_bridge.config import load_bus_config_text
    from drive_bridge.config.busbudget import budget_of
    env = {**os.environ, 'PYTHONPATH': str(REPO), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'ROS_DOMAIN_ID': os.environ.get('ROS_DOMAIN_ID') or str(random.randint(30, 99))}
    with tempfile.TemporaryDirectory(prefix='ros_cycle-') as tmp:
        work = Path(tmp)
        env['DRIVE_BRIDGE_CAN_DIR'] = str(work / 'can')
        print(f'{args.seconds:g} s per case; SYNC/lead/js in ms; skipped = grid points without SYNC of all; '
              'on time = SYNCs whose every set-point RPDO went out after the previous SYNC; '
              "js = TPDO reception -> /joint_states at the subscriber; CPU of the bridge (node and bus process); "
              "core = Master + TrajectoryExecutor alone, no rclpy (no subscriber: js '-'); "
              "idle p99/skip = a bare sleep loop on the grid in another process meanwhile: its interval p99 "
              "and skipped share (the machine's floor); rt = the bridge with master.realtime_priority "
              f"{REALTIME_PRIORITY} (SCHED_FIFO); ratio = naive/bridge, ratioR = naive/rt; "
              "'!' = over 70 % of 1 Mbit/s")
        if args.floods is not None:
            return flood_table(args, work, env)
        print(HEADER)
        for period_ms in args.periods:
            for axes in args.axes:
                budget = budget_of(load_bus_config_text(yaml.safe_dump(bus_data(axes, period_ms, 'x', args.maps))))
                results = {}
                for variant in args.variants:
                    try:
                        results[variant] = run_case(axes, period_ms, variant, args.seconds, work, env, args.maps)
                        print(row(axes, period_ms, budget.load or 0.0, variant, results[variant]), flush=True)
                    except Exception as exc:
                        print(f'{axes:4d} {period_ms:3g} {variant:6} could not run: {exc}', flush=True)
                for ours in ('bridge', 'rt'):
                    if ours in results and 'naive' in results:
                        print(ratio_row(results[ours], results['naive'], period_ms / 1000, ours), flush=True)
                goals = goal_line(results)
                if goals:
                    print(f'{"":14} {"goals":6} {goals}', flush=True)


def flood_table(args: argparse.Namespace, work: Path, env: dict[str, str]) -> None:
    """Each flood beside the bridge and beside core, with the case without flood, in one run."""
    axes, period_ms = args.axes[0], args.periods[0]
    print(f'floods at {axes} axes, {period_ms:g} ms, {args.maps} maps, trajectories streaming; '
          'skipped = grid points without SYNC; EMCY = EMCY frames from the drives (faults, heartbeat '
          'errors) in the window; js rate = /joint_states at the subscriber, share of the SYNC rate; '
          'ratio = bridge skipped / core skipped (goal <= 2, no EMCY, js >= 90 %)')
    print(f'{"flood":12} {"variant":7} {"skipped":>13} {"EMCY":>5} {"js rate":>8} {"CPU":>5} {"ratio":>6}')
    for flood in [None, *(args.floods or FLOODS)]:
        results = {}
        for variant in ('bridge', 'core'):
            try:
                r = results[variant] = run_case(axes, period_ms, variant, args.seconds, work, env, args.maps, flood)
            except Exception as exc:
                print(f'{flood or "none":12} {variant:7} could not run: {exc}', flush=True)
                continue
            expected = args.seconds / (period_ms / 1000)
            rate = f'{r["js_rate"] / expected:8.0%}' if variant == 'bridge' else f'{"-":>8}'
            ratio = ''
            if variant == 'core' and 'bridge' in results:
                core, bridge = r['skipped'], results['bridge']['skipped']
                ratio = f'{bridge / core:6.1f}' if core else ('1.0' if not bridge else '∞')
            print(f'{flood or "none":12} {variant:7} {r["skipped"]:6d}/{r["cycles"] + r["skipped"]:<6d} '
                  f'{r["emcy"]:5d} {rate} {r["cpu"]:5.0%} {ratio:>6}', flush=True)


if __name__ == '__main__':
    main(sys.argv[1:])
