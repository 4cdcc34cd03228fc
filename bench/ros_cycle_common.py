"""What every bridge variant of ``bench ros_cycle`` shares: the motion each streams on every
axis and the measurement window its bridge process opens (the full bridge in ros_cycle.py, the
core alone in ros_cycle_core.py).

A module of its own so that the core variant does not import ros_cycle.py, which imports
ros_cycle_core.py to run that variant.
"""
from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

AMPLITUDE = 0.3  # rad
FREQUENCY = 0.5  # Hz
WARMUP = 1.0  # s of streaming before the window opens
POINT_STEP = 0.05  # s between the streamed trajectory's points
TRAJECTORY_MARGIN = 15.0  # s of trajectory beyond warm-up and window: start-up, the probe's wait


def motion(t: float, k: int) -> float:
    """Offset from the start position of axis k at t s into the motion (zero velocity at 0)."""
    return AMPLITUDE * (1 - math.cos(2 * math.pi * FREQUENCY * t + 0.0 * k)) * (1 + 0.1 * k)


def motion_velocity(t: float, k: int) -> float:
    return AMPLITUDE * 2 * math.pi * FREQUENCY * math.sin(2 * math.pi * FREQUENCY * t) * (1 + 0.1 * k)


def trajectory_points(starts: list[float], seconds: float) -> list[tuple[float, list[float], list[float]]]:
    """(time, positions, velocities) of the streamed motion from ``starts``, long enough for
    ``seconds`` and the case's set-up; within the core's MAX_TRAJECTORY_POINTS."""
    from drive_bridge.streaming.trajectory import MAX_TRAJECTORY_POINTS
    total = seconds + TRAJECTORY_MARGIN
    step = max(POINT_STEP, total / (MAX_TRAJECTORY_POINTS - 1))
    return [(n * step, [start + motion(n * step, k) for k, start in enumerate(starts)],
             [motion_velocity(n * step, k) for k in range(len(starts))])
            for n in range(1, math.ceil(total / step) + 1)]


class Window:
    """Frames seen by the bus tap while the measurement window is open (time, id, sent), and the
    CPU of the processes that run the bridge (this one, and its bus process where it has one)
    over the window. With a bus process the frames are captured there (``capture``)."""

    def __init__(self) -> None:
        self.open = False
        self.frames: list[tuple[float, int, bool]] = []
        self.cpu = (0.0, 0.0)
        self.capture: Any = None  # path -> None: start ('' stops) the bus process's capture
        self.processes: list[int] = [os.getpid()]

    def __call__(self, msg: Any) -> None:
        if self.open:
            self.frames.append((msg.timestamp, msg.arbitration_id, not msg.is_rx))

    def _cpu(self) -> float:
        import psutil
        total = 0.0
        for pid in self.processes:
            t = psutil.Process(pid).cpu_times()
            total += t.user + t.system
        return total

    def run(self, ready: threading.Event) -> None:
        ready.wait()
        print('ready', flush=True)
        capture = tempfile.mktemp(suffix='.json')
        for line in sys.stdin:
            if line.strip() == 'start':
                if self.capture is not None:
                    self.capture(capture)
                self.cpu = (self._cpu(), time.perf_counter())
                self.open = True
            elif line.strip() == 'stop':
                self.open = False
                cpu_s, since = self.cpu
                self.cpu = ((self._cpu() - cpu_s) / (time.perf_counter() - since), 0.0)
                if self.capture is not None:
                    self.capture('')
                    self.frames = [tuple(f) for f in json.loads(Path(capture).read_text())]  # type: ignore[misc]
                    os.unlink(capture)
                return
