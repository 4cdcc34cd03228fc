"""The machine's floor for cycle figures: a bare sleep loop on a period grid, in a process of its
own, run beside a benchmark case so that both see the same load.

What it measures is what the machine alone costs a periodic thread: how late its wake-ups come,
how many grid points it misses (with the bridge's skip rule: a deadline less than half a period
ahead is skipped), and the share of wake-ups later than given thresholds (e.g. a synchronous
window). A benchmark prints its own figure next to this one, or as a ratio to it.

    .venv/bin/python -m bench.floor PERIOD_S SECONDS OUT.json [THRESHOLD_S ...]
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float('nan')


def sleep_loop(period: float, seconds: float, thresholds: tuple[float, ...] = ()) -> dict[str, Any]:
    """Figures of a sleep loop on the ``period`` grid for ``seconds``: wake-up lateness, skipped
    grid points, the interval p99 between wake-ups (as a SYNC interval, skips included)."""
    deadline = time.perf_counter() + period
    end = deadline + seconds
    skipped = cycles = 0
    late: list[float] = []
    wakes: list[float] = []
    while deadline < end:
        delay = deadline - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        woke = time.perf_counter()
        late.append(woke - deadline)
        wakes.append(woke)
        cycles += 1
        deadline += period
        while deadline - woke < period / 2:
            deadline += period
            skipped += 1
    intervals = [b - a for a, b in zip(wakes, wakes[1:])]
    return {'cycles': cycles, 'skipped': skipped, 'skip_share': skipped / max(1, cycles + skipped),
            'late_p50': _pct(late, 0.5), 'late_p99': _pct(late, 0.99), 'late_max': max(late, default=float('nan')),
            'interval_p99': _pct(intervals, 0.99),
            'late_share': {str(t): sum(1 for x in late if x > t) / max(1, len(late)) for t in thresholds}}


class Floor:
    """The sleep loop in a process of its own while a case runs: ``with Floor(...) as floor:``,
    then ``floor.result``."""

    def __init__(self, period: float, seconds: float, work: Path, thresholds: tuple[float, ...] = ()) -> None:
        self.out = work / f'floor-{time.monotonic_ns()}.json'
        self._args = [sys.executable, '-m', 'bench.floor', repr(period), repr(seconds), str(self.out),
                      *map(repr, thresholds)]
        self.result: dict[str, Any] = {}

    def __enter__(self) -> Floor:
        self._process = subprocess.Popen(self._args, cwd=REPO)
        return self

    def __exit__(self, *_exc: object) -> None:
        self._process.wait(120)
        self.result = json.loads(self.out.read_text()) if self.out.exists() else {}


def main(argv: list[str]) -> None:
    period, seconds, out, *thresholds = argv
    Path(out).write_text(json.dumps(sleep_loop(float(period), float(seconds), tuple(map(float, thresholds)))))


if __name__ == '__main__':
    main(sys.argv[1:])
