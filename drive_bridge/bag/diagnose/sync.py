"""SYNC (COB-ID 0x080): period histogram and jitter percentiles against the configured
period (else the median), and SYNC gaps."""
from __future__ import annotations

from typing import Any

import numpy as np

from drive_bridge.bag.diagnose.model import Context, Severity

PERCENTILES = (50, 90, 99, 99.9)
GAP_FACTOR = 3.0


class SyncStats:
    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.times: list[float] = []
        self.periods: np.ndarray = np.empty(0)
        self.nominal: float | None = None
        self.jitter: dict[str, float] = {}
        self.gaps = 0

    def finish(self) -> None:
        if len(self.times) < 3:
            return
        times = np.asarray(self.times)
        self.periods = np.diff(times)
        nominal = self.ctx.sync_period or float(np.median(self.periods))
        self.nominal = nominal
        deviation = np.abs(self.periods - nominal)
        self.jitter = {f'p{p:g}': float(np.percentile(deviation, p)) for p in PERCENTILES}
        self.jitter['max'] = float(deviation.max())
        gaps = np.nonzero(self.periods > GAP_FACTOR * nominal)[0]
        self.gaps = int(gaps.size)
        if gaps.size:
            worst = int(gaps[np.argmax(self.periods[gaps])])
            self.ctx.add(Severity.WARNING, float(times[worst]), None,
                         f'SYNC gap: {gaps.size} period(s) over {GAP_FACTOR:g}x the nominal {nominal * 1000:.2f} ms, '
                         f'longest {self.periods[worst] * 1000:.1f} ms',
                         'the SYNC producer stalled (a busy master thread, or the bus was saturated)', 'sync-gap')

    def to_json(self) -> dict[str, Any]:
        return {'count': len(self.times), 'nominal_s': self.nominal, 'gaps': self.gaps,
                'jitter_s': self.jitter}
