"""Motion check benchmark: what validating and planning a trajectory costs the process that
runs the SYNC cycle (the bus process), where it holds the GIL.

For 5,000-point trajectories of 4 joints (the most one trajectory may have) in each
interpolation (linear: positions; cubic: positions and velocities; quintic: with
accelerations), it times ``validate`` (the per-value checks, the conversion to arrays), both
``validate`` and ``plan`` (splines, the segment-by-segment motion check, the past-stamp blend:
what ``TrajectoryExecutor.submit`` does), and ``plan`` with
``scale_to_limits`` on a trajectory 3x too fast (the stretch rounds). Median and max of
``--repeat`` runs, in ms. Figures on a shared, busy machine are noisy: say so beside them.

    .venv/bin/python -m bench motion_check [--points 5000] [--joints 4] [--repeat 20]
"""
from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from drive_bridge.model import AxisLimits
from drive_bridge.streaming.planning import plan
from drive_bridge.streaming.trajectory import JointSample, Trajectory, TrajectoryPoint, validate

PERIOD = 0.004


def trajectory(points: int, joints: int, order: int, speed: float = 1.0) -> Trajectory:
    """A sum of sines sampled every 4 ms: velocity up to 1.5 * speed rad/s."""
    t = np.arange(1, points + 1) * PERIOD
    omega = 1.0 * speed
    names = tuple(f'joint{j}' for j in range(joints))
    rows = []
    for time_ in t.tolist():
        phase = [omega * time_ + j for j in range(joints)]
        positions = tuple(float(np.sin(p)) + 0.5 * float(np.sin(2 * p)) for p in phase)
        velocities = tuple(omega * (float(np.cos(p)) + float(np.cos(2 * p))) for p in phase) if order >= 3 else ()
        accelerations = (tuple(-omega ** 2 * (float(np.sin(p)) + 2 * float(np.sin(2 * p))) for p in phase)
                         if order == 5 else ())
        rows.append(TrajectoryPoint(time_, positions, velocities, accelerations))
    return Trajectory(names, tuple(rows))


def timed(work: Callable[[], object], repeat: int) -> tuple[float, float]:
    figures = []
    for _ in range(repeat):
        start = time.perf_counter()
        work()
        figures.append((time.perf_counter() - start) * 1000)
    return statistics.median(figures), max(figures)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog='python -m bench motion_check')
    parser.add_argument('--points', type=int, default=5000)
    parser.add_argument('--joints', type=int, default=4)
    parser.add_argument('--repeat', type=int, default=20)
    args = parser.parse_args(argv)
    limits = {f'joint{j}': AxisLimits(-3.0, 3.0, 2.0, 40.0) for j in range(args.joints)}

    def states(_at: float) -> dict[str, JointSample]:  # each joint's sine at t = 0 (speed 1)
        return {f'joint{j}': JointSample(float(np.sin(j) + 0.5 * np.sin(2 * j)), float(np.cos(j) + np.cos(2 * j)),
                                         float(-np.sin(j) - 2 * np.sin(2 * j))) for j in range(args.joints)}
    print(f'{args.points} points x {args.joints} joints, {args.repeat} runs; ms median / max')
    print('| interpolation | validate | validate + plan (the motion check) | plan, 3x too fast, scale_to_limits |')
    print('|---|---|---|---|')
    for order, name in ((1, 'linear'), (3, 'cubic'), (5, 'quintic')):
        traj = trajectory(args.points, args.joints, order)
        fast = trajectory(args.points, args.joints, order, speed=3.0)
        v = timed(lambda t=traj: validate(t, limits, 'bench'), args.repeat)  # type: ignore[misc]
        p = timed(lambda t=traj: plan(t, 100.0, 100.0, states, limits, False, 'bench',  # type: ignore[misc]
                                      arrays=validate(t, limits, 'bench')), args.repeat)
        s = timed(lambda t=fast: plan(t, 100.0, 100.0, states, limits, True, 'bench'),  # type: ignore[misc]
                  max(3, args.repeat // 4))
        print(f'| {name} | {v[0]:.1f} / {v[1]:.1f} | {p[0]:.1f} / {p[1]:.1f} | {s[0]:.1f} / {s[1]:.1f} |')


if __name__ == '__main__':
    main()
