"""bench ros_cycle's ``core`` variant: the bridge's core alone in the bridge process, no rclpy.

Master + TrajectoryExecutor on the same config and drives, streaming the subscriber's motion
on every axis and reading the joint feedback each cycle as the bridge does (without publishing):
the most that moving the cycle and the CAN I/O into a process of their own could gain.
"""
from __future__ import annotations

import gc
import json
import os
import sys
import threading
from pathlib import Path

from bench.ros_cycle_common import WARMUP, Window, trajectory_points

ENABLE_TIMEOUT = 30.0  # s, as the bridge role's wait for OPERATION ENABLED


def core_role(config_path: str, seconds: float, out: str) -> None:
    from drive_bridge.config import load_bus_config
    from drive_bridge.master.master import Master
    from drive_bridge.streaming.executor import TrajectoryExecutor
    from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint
    config = load_bus_config(config_path)
    master = Master(config)
    window = Window()
    master.add_frame_listener(window)
    master.start()
    executor = TrajectoryExecutor(master.axes, cycle_period=config.master.cycle_period)
    master.add_cycle_listener(executor.check)
    master.add_emcy_listener(executor.on_emcy, safety=True)
    axes = list(master.axes.values())

    def read_feedback() -> None:  # what the bridge reads for /joint_states each cycle, unpublished
        for axis in axes:
            axis.feedback()
    master.add_feedback_listener(read_feedback)
    try:
        master.wait_until_operational(ENABLE_TIMEOUT)
        for axis in axes:
            axis.enable(timeout=ENABLE_TIMEOUT)
    except Exception as exc:
        print(f'core: {exc}', file=sys.stderr, flush=True)
        os._exit(3)
    names = sorted(master.axes, key=lambda n: int(n[1:]))
    starts = [master.axes[j].feedback()[1] for j in names]
    points = tuple(TrajectoryPoint(t, tuple(p), tuple(v))
                   for t, p, v in trajectory_points(starts, seconds + WARMUP))
    executor.submit(Trajectory(tuple(names), points), 'core')  # starts now, as the bridge's (stamp zero)
    if 'rclpy' in sys.modules:  # the variant's point: the core never imports it
        print('core: rclpy was imported in the core variant', file=sys.stderr, flush=True)
        os._exit(3)
    gc.collect()
    gc.freeze()  # as drive_bridge.ros.main.run does
    ready = threading.Event()
    ready.set()
    window.run(ready)
    s = master.sync.stats() if master.sync is not None else None
    Path(out).write_text(json.dumps({
        'frames': window.frames, 'cpu': window.cpu[0],
        'own': {'skipped': s.skipped, 'cycles': s.cycles} if s else None,
        'streaming': [h.state for h in executor.active()]}))
    master.stop()
    os._exit(0)
