"""Time a simulated slave spends handling SYNC frames (RPDO apply, model step, TPDOs):
what ``python -m drive_bridge.sim.bench`` and the performance tests read."""
from __future__ import annotations

import statistics
from collections import deque


class SyncCost:
    """Time spent handling SYNC frames (RPDO apply, model step, TPDOs), for benchmarks."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.count = 0
        self.total = 0.0
        self.max = 0.0
        self.recent: deque[float] = deque(maxlen=10000)

    def add(self, seconds: float) -> None:
        self.count += 1
        self.total += seconds
        self.max = max(self.max, seconds)
        self.recent.append(seconds)

    @property
    def mean(self) -> float:
        return self.total / self.count if self.count else 0.0

    @property
    def median(self) -> float:
        return statistics.median(self.recent) if self.recent else 0.0
