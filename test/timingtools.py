"""Timing bounds for tests that run on a slow, busy 2-core machine (two suites at once, or the
suite beside ``bench ros_cycle --quick``).

A test asserts behaviour: a reaction comes, and not before its time; a cycle goes on; a stream
follows its path most of the time. How fast, how often late, how many cycles skipped are the
machine's figures as much as the bridge's: they are measured by the benchmarks (bench/cycle.py,
bench/reactions.py, bench/tracking.py), beside the machine's floor. Upper bounds on time add
BUSY_SLACK to the nominal figure; shares are bounded where a regression would be gross.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from waittools import wait_for

# s: how long a busy 2-core machine may hold a test's threads off the CPU. Seen: 0.36-0.4 s
# stalls of a process in CI, a 10-million-step loop taking 2.4-3.3 s instead of ~0.8 s.
BUSY_SLACK = 1.0


def quantile(values: Sequence[float], q: float) -> float:
    """The ``q`` quantile of ``values`` (nearest rank; q=0.5 the median, 1.0 the max)."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


class CycleWatch:
    """The SYNC cycles a master ran and the grid points it skipped since this was made: a core
    Master's own counts, or a bus node's (``node.master``, the bus process's client) from
    snapshots the bus process took after each read."""

    def __init__(self, master: Any) -> None:
        self.master = master
        self.cycles0, self.skipped0 = self._counts()

    def _counts(self) -> tuple[int, int]:
        sync = getattr(self.master, 'sync', None)
        if sync is None:  # the bus process's client
            sync = fresh_snapshot(self.master).sync
        return int(sync.cycles), int(sync.skipped)

    @property
    def cycles(self) -> int:
        return self._counts()[0] - self.cycles0

    @property
    def skipped(self) -> int:
        return self._counts()[1] - self.skipped0

    @property
    def skip_share(self) -> float:
        """Skipped grid points over all grid points (0 before any)."""
        return self.skipped / max(1, self.cycles + self.skipped)

    def __repr__(self) -> str:
        return f'{self.cycles} cycles, {self.skipped} grid points skipped'


def stamp_of(msg: Any) -> float:
    """A ROS message's header stamp in s (wall clock)."""
    return float(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)


def stamped_count(messages: Sequence[Any], start: float, end: float) -> int:
    """How many of ``messages`` (with a header) were stamped in [start, end): a rate counted by
    the publisher's clock, not by arrival, so that a delivery backlog after a stall does not count."""
    return sum(1 for m in list(messages) if start <= stamp_of(m) < end)


def assert_follows(errors: Sequence[float], tolerance: float, limit: float | None = None, share: float = 0.95) -> None:
    """A stream followed its path: ``share`` of the samples' errors within ``tolerance``, every
    one within ``limit`` (default 3 x tolerance: a cycle stalled on a busy machine). The figures
    themselves: `python -m bench tracking`."""
    assert errors, 'no path samples'
    limit = 3 * tolerance if limit is None else limit
    within, worst = quantile(errors, share), max(errors)
    assert within < tolerance and worst < limit, \
        f'path error {100 * share:.0f} % {within:.4f} (bound {tolerance}), max {worst:.4f} (bound {limit})'


def _progress(snapshot: Any) -> tuple[int, int, int]:
    sync = snapshot.sync
    return (sync.cycles if sync is not None else 0, snapshot.traffic.rx_frames, snapshot.traffic.tx_frames)


def fresh_snapshot(node: Any, timeout: float = 5.0) -> Any:
    """The bus as the bus process saw it after this call (``node``: a bus node, or its client).
    ``master.snapshot()`` answers with the last snapshot it has and asks for the next one; an
    answer may be on its way already, so the second snapshot that shows progress was taken after
    the call."""
    client = getattr(node, 'master', node)
    seen = [_progress(client.snapshot())]

    def newer() -> Any | None:
        snapshot = client.snapshot()
        if _progress(snapshot) > seen[-1]:
            seen.append(_progress(snapshot))
            if len(seen) == 3:
                return snapshot
        return None
    return wait_for(newer, timeout, 'a new snapshot from the bus process')
