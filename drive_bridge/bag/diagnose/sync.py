"""SYNC (COB-ID 0x080): period histogram and jitter percentiles against the configured
period (else the median), and SYNC gaps. Plain Python (numpy is not imported to diagnose)."""
from __future__ import annotations

from typing import Any

from drive_bridge.bag.diagnose.model import Context, Severity

PERCENTILES = (50, 90, 99, 99.9)
GAP_FACTOR = 3.0


def percentile(ordered: list[float], p: float) -> float:
    """Linear interpolation between closest ranks (numpy's default) of an ordered list."""
    if not ordered:
        return 0.0
    rank = (len(ordered) - 1) * p / 100.0
    low = int(rank)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (rank - low)


class SyncStats:
    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.times: list[float] = []
        self.periods: list[float] = []
        self.nominal: float | None = None
        self.jitter: dict[str, float] = {}
        self.gaps = 0

    def finish(self) -> None:
        times = self.times
        if len(times) < 3 or not self.ctx.timing:
            return
        self.periods = periods = [b - a for a, b in zip(times, times[1:])]
        nominal = self.ctx.sync_period or percentile(sorted(periods), 50)
        self.nominal = nominal
        deviation = sorted(abs(p - nominal) for p in periods)
        self.jitter = {f'p{p:g}': percentile(deviation, p) for p in PERCENTILES}
        self.jitter['max'] = deviation[-1]
        limit = GAP_FACTOR * nominal
        gaps = [i for i, p in enumerate(periods) if p > limit]
        self.gaps = len(gaps)
        if gaps:
            worst = max(gaps, key=lambda i: periods[i])
            self.ctx.add(Severity.WARNING, times[worst], None,
                         f'SYNC gap: {len(gaps)} period(s) over {GAP_FACTOR:g}x the nominal {nominal * 1000:.2f} ms, '
                         f'longest {periods[worst] * 1000:.1f} ms',
                         'the SYNC producer stalled (a busy master thread, or the bus was saturated)', 'sync-gap')

    @property
    def rate(self) -> float | None:
        """SYNC frames per second, when the period is known."""
        return 1.0 / self.nominal if self.nominal else None

    def to_json(self) -> dict[str, Any]:
        return {'count': len(self.times), 'nominal_s': self.nominal, 'gaps': self.gaps,
                'jitter_s': self.jitter}
