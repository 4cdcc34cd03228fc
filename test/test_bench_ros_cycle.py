"""bench ros_cycle's figures from the frames a bridge's tap saw (synthetic frames)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.ros_cycle import HEADER, analyse, motion, probe_role, row, trajectory_points
from drive_bridge.streaming.trajectory import MAX_TRAJECTORY_POINTS

P = 0.002


def frames(skip: int, late: int) -> list[tuple[float, int, bool]]:
    """SYNC every 2 ms on the grid but point ``skip``; both nodes' set-points 0.3 ms before
    each SYNC, node 2's for SYNC ``late`` after it instead."""
    out = []
    for n in range(1, 101):
        t = n * P
        if n == skip:
            continue
        for node in (1, 2):
            out.append((t - 0.0003 + (0.0004 if n == late and node == 2 else 0.0), 0x300 + node, True))
        out.append((t, 0x080, True))
        out.append((t + 0.0002, 0x180 + 1, False))  # a received TPDO: not a set-point
    return sorted(out)


def test_skipped_sync_and_late_setpoints_are_counted() -> None:
    result = analyse({'frames': frames(skip=50, late=70), 'cpu': 0.25},
                     [[10.0015, 10.0], [20.003, 20.0]], axes=2, period=P)
    assert result['cycles'] == 98 and result['skipped'] == 1
    assert result['sync_p50'] == pytest.approx(P) and result['sync_max'] == pytest.approx(2 * P)
    # SYNC 70 misses node 2's set-point (it went out after), SYNC 71 gets two of node 2 and one of node 1
    assert result['on_time'] == pytest.approx(97 / 98)
    assert result['lead_p50'] == pytest.approx(0.0003)
    assert result['js_p50'] == pytest.approx(0.0015, abs=1e-3) and result['cpu'] == 0.25


def test_a_bridge_that_sends_no_setpoints_is_never_on_time() -> None:
    no_setpoints = [f for f in frames(skip=0, late=0) if f[1] == 0x080]
    assert analyse({'frames': no_setpoints, 'cpu': 0.0}, [], axes=1, period=P)['on_time'] == 0.0


def test_the_machine_floor_and_a_variant_without_subscriber_are_shown() -> None:
    probe = {'skipped': 1, 'cycles': 99, 'late_p99': 0.0001, 'interval_p99': 0.0023}
    result = analyse({'frames': frames(skip=50, late=0), 'cpu': 0.2, 'probe': probe}, [], axes=2, period=P)
    assert result['idle_p99'] == pytest.approx(0.0023) and result['idle_skip'] == pytest.approx(0.01)
    line = row(2, 2, 0.1, 'core', result)
    assert len(line) == len(HEADER)
    # no subscriber: the js columns say '-', the idle p99 column the probe's figure in ms
    assert line.split()[-5:] == ['-', '-', '20%', '2.30', '1.0%']


def test_the_probe_measures_its_own_wake_up_intervals(tmp_path: Path) -> None:
    out = tmp_path / 'probe.json'
    probe_role(P, 0.1, str(out))
    figures = json.loads(out.read_text())
    assert figures['skipped'] + figures['cycles'] == pytest.approx(0.1 / P, abs=2)
    assert P * 0.9 <= figures['interval_p99'] < 0.1


def test_the_streamed_trajectory_fits_the_core_limit_and_outlasts_the_window() -> None:
    for seconds in (3.0, 11.0, 600.0):
        points = trajectory_points([0.0, 1.0], seconds)
        assert len(points) <= MAX_TRAJECTORY_POINTS and points[-1][0] >= seconds
        assert points[0][1][1] == pytest.approx(1.0 + motion(points[0][0], 1))
