"""The soak benchmark, 30 seconds of it: 4 axes streaming while faults from the catalogue
are injected at random. Bounds are generous (a noisy 2-core CI): every fault reported and
recovered from, no frame lost, no thread left over, memory growth far under 20 MB."""
from __future__ import annotations

import pytest

from bench.soak import CATALOGUE, report, run

pytestmark = [pytest.mark.slow, pytest.mark.sim]  # 30 s of simulated drives


def test_thirty_seconds_of_faults_while_streaming(capsys) -> None:
    result = run(30.0, seed=7, log=lambda _line: None)
    report(result)
    print(capsys.readouterr().out)  # kept in the test log for a failure's post-mortem
    injected = sum(t.injected for t in result.tallies.values())
    assert injected >= 5
    misses = [m for t in result.tallies.values() for m in t.misses]
    assert not misses, misses
    assert all(t.detected == t.recovered == t.injected for t in result.tallies.values())
    assert set(result.tallies) == set(CATALOGUE)
    assert result.frames_lost == 0 and result.frames_received > 10_000
    assert result.threads_end <= result.threads_start + 1
    assert result.rss_end - result.rss_start < 30 * 1024 * 1024
    before, after = result.naive  # the baseline: canopen alone goes deaf after one receive error
    assert before > 50 and after == 0
