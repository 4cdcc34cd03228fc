"""Recording benchmark: does the recorder keep up with a busy bus, and does it slow the SYNC cycle?

1. Throughput: a sender offers N frames/s (default 20,000: more than two saturated 1 Mbit/s
   buses) on a python-can virtual bus for a few seconds; a receive thread reads them through the
   bridge's TappedBus, as the master's does. Recorded three ways, in the same run:
   - ``recorder``: drive_bridge.bag.recorder.Recorder (the tap listener only queues; a writer
     thread encodes and writes rotating MCAP splits);
   - ``naive``: a rosbags Writer called synchronously in the tap callback (typestore CDR), the
     obvious way to do it.
   and ``none`` (the bus and tap alone) for the CPU the bus itself costs.
   Printed: offered, written, dropped, process CPU, and how long the receive thread lagged
   behind the bus (max age of a frame when the tap saw it): a slow tap callback holds up the
   bus thread, which in the bridge is what receives the PDOs for the next cycle.
2. SYNC cycles: the demo bus (4 simulated CiA 402 axes) run by the master at a 4 ms SYNC, with
   no recording, with the recorder, and with the naive writer; skipped SYNC cycles counted by the
   master (a cycle whose deadline has passed is skipped). Then the same through the ROS bus node:
   no recording, recording (``record.start``), and one subscriber on ``~/can_frames`` in another
   process (recording through that topic).

    .venv/bin/python -m bench recording [--rate 20000] [--seconds 5] [--sync-seconds 10] [--repeat 1]
"""
from __future__ import annotations

import argparse
import copy
import statistics
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import can
import numpy as np
import psutil
import yaml
from rosbags.rosbag2 import StoragePlugin, Writer

from drive_bridge.bag.recorder import Recorder
from drive_bridge.bag.source import open_recording
from drive_bridge.bag.typestore import typestore
from drive_bridge.bag.writer import FRAME_TYPE, FRAMES_TOPIC
from drive_bridge.config import parse_bus_config
from drive_bridge.master.bus import FrameTap, TappedBus
from drive_bridge.master.master import Master
from drive_bridge.resources import shipped_config
from drive_bridge.sim import SimulatedBus

BATCH_PERIOD = 0.001  # s: the sender offers rate/1000 frames every millisecond


class NaiveWriter:
    """The baseline: a rosbags Writer in the tap callback, one typestore serialization per frame."""

    def __init__(self, path: Path) -> None:
        store = typestore()
        self.store = store
        self.writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.connection = self.writer.add_connection(FRAMES_TOPIC, FRAME_TYPE, typestore=store)
        self.types = store.types
        self.frames = 0
        self._lock = threading.Lock()

    def on_frame(self, msg: can.Message) -> None:
        t = self.types
        stamp = round(msg.timestamp * 1e9)
        frame = t[FRAME_TYPE](
            header=t['std_msgs/msg/Header'](
                stamp=t['builtin_interfaces/msg/Time'](sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id='bench'),
            id=msg.arbitration_id, is_extended=msg.is_extended_id, is_rtr=msg.is_remote_frame,
            is_error=msg.is_error_frame, dlc=msg.dlc, data=np.frombuffer(bytes(msg.data), dtype=np.uint8),
            direction=0 if msg.is_rx else 1)
        with self._lock:  # listeners run in several threads
            self.writer.write(self.connection, stamp, self.store.serialize_cdr(frame, FRAME_TYPE))
            self.frames += 1

    def stop(self) -> tuple[int, int]:
        self.writer.close()
        return self.frames, 0


@dataclass
class ThroughputRow:
    way: str
    offered: int
    tapped: int
    written: int
    dropped: int
    cpu: float  # fraction of one core, whole process, while offering and draining
    lag_max: float  # s, the oldest a frame was when the tap saw it
    drain: float  # s after the sender stopped until everything was written


def throughput(way: str, rate: int, seconds: float, directory: Path) -> ThroughputRow:
    channel = f'bench-recording-{time.monotonic_ns()}'
    sender = can.Bus(interface='virtual', channel=channel)
    tap = FrameTap()
    bus = TappedBus(can.Bus(interface='virtual', channel=channel), tap)
    tapped = [0]
    lag = [0.0]

    def measure(msg: can.Message) -> None:
        tapped[0] += 1
        age = time.time() - msg.timestamp
        if age > lag[0]:
            lag[0] = age
    tap.add_listener(measure)
    sink: Recorder | NaiveWriter | None = None
    if way == 'recorder':
        sink = Recorder(directory / way, channel='bench', split_bytes=50_000_000)
    elif way == 'naive':
        sink = NaiveWriter(directory / way)
    if sink is not None:
        tap.add_listener(sink.on_frame)
    stop = threading.Event()

    def receive() -> None:
        while not stop.is_set() or tapped[0] < offered[0]:
            bus.recv(0.05)
    offered = [0]
    receiver = threading.Thread(target=receive, daemon=True)
    receiver.start()
    process = psutil.Process()
    cpu0 = sum(process.cpu_times()[:2])
    t0 = time.monotonic()
    per_batch = max(1, round(rate * BATCH_PERIOD))
    data = bytes(8)
    deadline = t0
    while time.monotonic() - t0 < seconds:
        for _ in range(per_batch):
            sender.send(can.Message(arbitration_id=0x181 + offered[0] % 4, data=data, is_extended_id=False))
            offered[0] += 1
        deadline += BATCH_PERIOD
        pause = deadline - time.monotonic()
        if pause > 0:
            time.sleep(pause)
    sent_at = time.monotonic()
    stop.set()
    receiver.join()
    written = dropped = 0
    if isinstance(sink, Recorder):
        stats = sink.stop()
        written, dropped = stats.frames, stats.dropped
    elif sink is not None:
        written, dropped = sink.stop()
    drain = time.monotonic() - sent_at
    cpu = (sum(process.cpu_times()[:2]) - cpu0) / (time.monotonic() - t0)
    bus.shutdown()
    sender.shutdown()
    if isinstance(sink, Recorder):
        assert sum(1 for _ in open_recording(directory / way).frames()) == written
    return ThroughputRow(way, offered[0], tapped[0], written, dropped, cpu, lag[0], drain)


@dataclass
class SyncRow:
    way: str
    cycles: int
    skipped: int
    frames: int
    dropped: int


def sync_cycles(way: str, seconds: float, directory: Path) -> SyncRow:
    data = yaml.safe_load(shipped_config('demo.yaml').read_text())
    data = copy.deepcopy(data)
    data['bus']['channel'] = f'bench-sync-{time.monotonic_ns()}'
    data['master']['sync_period'] = 4000
    config = parse_bus_config(data, 'bench', shipped_config('demo.yaml').parent)
    sim = SimulatedBus(config).start()
    master = Master(config)
    sink: Recorder | NaiveWriter | None = None
    if way == 'recorder':
        sink = Recorder(directory / f'sync-{way}', channel='bench')
    elif way == 'naive':
        sink = NaiveWriter(directory / f'sync-{way}')
    if sink is not None:
        master.add_frame_listener(sink.on_frame)
    try:
        master.start()
        master.wait_until_operational(15.0)
        assert master.sync is not None
        cycles0, skipped0 = master.sync.cycles, master.sync.skipped
        time.sleep(seconds)
        cycles, skipped = master.sync.cycles - cycles0, master.sync.skipped - skipped0
    finally:
        master.stop()
        sim.stop()
    frames = dropped = 0
    if isinstance(sink, Recorder):
        stats = sink.stop()
        frames, dropped = stats.frames, stats.dropped
    elif sink is not None:
        frames, dropped = sink.stop()
    return SyncRow(way, cycles, skipped, frames, dropped)


SUBSCRIBER = """
import sys, rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from drive_bridge_interfaces.msg import CanFrame
rclpy.init()
node = Node('bench_can_frames_subscriber')
count = [0]
node.create_subscription(CanFrame, sys.argv[1], lambda m: count.__setitem__(0, count[0] + 1), QoSProfile(depth=1000))
print('ready', flush=True)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
    pass
"""


def ros_sync_cycles(way: str, seconds: float, directory: Path) -> SyncRow:
    """The bus node itself (rclpy): no recording, ~/record, or one ~/can_frames subscriber (another process)."""
    import os
    import subprocess
    import sys

    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.logging import LoggingSeverity
    from rclpy.parameter import Parameter

    from drive_bridge.ros.node import BusNode

    data = yaml.safe_load(shipped_config('demo.yaml').read_text())
    data['bus']['channel'] = f'bench-ros-{time.monotonic_ns()}'
    context = Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    params = [Parameter('config_yaml', value=yaml.safe_dump(data)), Parameter('sync_period', value=0.004),
              Parameter('record.path', value=str(directory)), Parameter('record.start', value=way == 'record')]
    node = BusNode(context=context, parameter_overrides=params, node_name=f'bench_{way}')
    node.get_logger().set_level(LoggingSeverity.WARN)
    executor.add_node(node)
    spinning = threading.Event()

    def spin() -> None:
        while not spinning.is_set():
            executor.spin_once(timeout_sec=0.05)
    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    subscriber = None
    try:
        if way == 'can_frames':
            subscriber = subprocess.Popen([sys.executable, '-c', SUBSCRIBER, f'/bench_{way}/can_frames'],
                                          stdout=subprocess.PIPE, text=True, env=os.environ.copy())
            assert subscriber.stdout is not None and subscriber.stdout.readline().strip() == 'ready'
        node.master.wait_until_operational(15.0)
        time.sleep(1.0)  # the node sees the subscriber (counted every 0.5 s)
        sync = node.master.sync
        assert sync is not None
        cycles0, skipped0 = sync.cycles, sync.skipped
        time.sleep(seconds)
        cycles, skipped = sync.cycles - cycles0, sync.skipped - skipped0
    finally:
        node.close()
        stats = node.bridge.recording.last
        spinning.set()
        spinner.join(5)
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        if subscriber is not None:
            subscriber.terminate()
            subscriber.wait(10)
    return SyncRow(way, cycles, skipped, stats.frames if stats else 0, stats.dropped if stats else 0)


def interleaved(ways: tuple[str, ...], repeat: int, run: Callable[[str, int], SyncRow]) -> list[SyncRow]:
    """Each way once per round, rounds repeated: a machine whose load drifts affects every way alike."""
    rows: dict[str, list[SyncRow]] = {way: [] for way in ways}
    for i in range(max(1, repeat)):
        for way in ways:
            rows[way].append(run(way, i))
    result = []
    for way in ways:
        row = median(rows[way], SyncRow)
        assert isinstance(row, SyncRow)
        result.append(row)
    return result


def median(rows: list, make: Callable[..., object]) -> object:
    first = rows[0]
    values = {k: (statistics.median(getattr(r, k) for r in rows) if isinstance(v, (int, float)) else v)
              for k, v in vars(first).items()}
    return make(**values)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog='bench recording', description=__doc__.split('\n\n')[0])
    parser.add_argument('--rate', type=int, default=20_000, help='frames/s offered')
    parser.add_argument('--seconds', type=float, default=5.0, help='offering time per run')
    parser.add_argument('--sync-seconds', type=float, default=10.0, help='SYNC measurement time per run')
    parser.add_argument('--repeat', type=int, default=1, help='runs per row (median)')
    parser.add_argument('--no-ros', dest='ros', action='store_false',
                        help='skip the rows through the ROS bus node (rclpy)')
    options = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix='bench-recording-') as tmp:
        directory = Path(tmp)
        print(f'Throughput: {options.rate} frames/s offered on a virtual bus for {options.seconds:g} s')
        print(f'{"way":<10}{"offered":>9}{"tapped":>9}{"written":>9}{"dropped":>9}{"CPU":>8}'
              f'{"tap lag max":>13}{"drain":>9}')
        results = {}
        for way in ('none', 'recorder', 'naive'):
            runs = []
            for i in range(max(1, options.repeat)):
                runs.append(throughput(way, options.rate, options.seconds, directory / f'{way}{i}'))
            row = median(runs, ThroughputRow)
            assert isinstance(row, ThroughputRow)
            results[way] = row
            print(f'{row.way:<10}{row.offered:>9.0f}{row.tapped:>9.0f}{row.written:>9.0f}{row.dropped:>9.0f}'
                  f'{row.cpu * 100:>7.0f}%{row.lag_max * 1000:>10.1f} ms{row.drain:>7.2f} s', flush=True)
        ours, naive, bare = results['recorder'], results['naive'], results['none']
        print(f'tap lag, naive / recorder: {naive.lag_max / max(ours.lag_max, 1e-6):.1f}x; recording CPU '
              f'(over the bus alone), naive / recorder: '
              f'{(naive.cpu - bare.cpu) / max(ours.cpu - bare.cpu, 1e-6):.2f}x')
        print()
        print(f'SYNC at 4 ms, demo bus (4 simulated axes), {options.sync_seconds:g} s per run')
        print(f'{"way":<10}{"cycles":>8}{"skipped":>9}{"skipped %":>11}{"frames":>9}{"dropped":>9}')
        for sync in interleaved(('none', 'recorder', 'naive'), options.repeat,
                                lambda way, i: sync_cycles(way, options.sync_seconds, directory / f'{way}{i}')):
            print_sync(sync)
        if options.ros:
            print()
            print(f'SYNC at 4 ms through the ROS bus node (demo bus), {options.sync_seconds:g} s per run')
            print(f'{"way":<12}{"cycles":>6}{"skipped":>9}{"skipped %":>11}{"frames":>9}{"dropped":>9}')
            for sync in interleaved(('none', 'record', 'can_frames'), options.repeat,
                                    lambda way, i: ros_sync_cycles(way, options.sync_seconds,
                                                                   directory / f'ros-{way}{i}')):
                print_sync(sync, 12)


def print_sync(sync: SyncRow, width: int = 10) -> None:
    print(f'{sync.way:<{width}}{sync.cycles:>{18 - width}.0f}{sync.skipped:>9.0f}'
          f'{100 * sync.skipped / max(sync.cycles + sync.skipped, 1):>10.1f}%'
          f'{sync.frames:>9.0f}{sync.dropped:>9.0f}', flush=True)
