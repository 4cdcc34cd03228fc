"""The motion between waypoints, checked as the executor will sample it: every segment of
every joint's spline against the joint's position, velocity and acceleration limits.

Waypoints inside the limits say little about the path between them: a cubic segment
between two in-limit points may overshoot a position limit, two points 1 ms apart may ask
for thousands of rad/s. So each segment's polynomial (the very coefficients the executor
samples every cycle) is evaluated where its extremes lie: a linear or cubic segment exactly
(its ends and the roots and vertex of its velocity), a quintic at ``SAMPLES`` evenly spaced
instants; all segments at once with numpy: a 5,000-point trajectory of 4 joints costs a few
milliseconds (bench/motion_check.py), so it can run beside the SYNC cycle under one GIL.

Positions-only (linear) trajectories change velocity at a waypoint within one cycle: the
acceleration limit cannot apply to them (their velocity limit does); give velocities for a
path whose acceleration is checked.

``stretch_factors`` says by how much each segment's duration must grow for the velocity
and acceleration limits to hold (``trajectory.scale_to_limits``); a position violation
cannot be cured by time and is always refused.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from drive_bridge.model import AxisLimits

Array = npt.NDArray[np.float64]
SAMPLES = 9  # evenly spaced instants per quintic segment, both ends included (and its jerk's roots)
TOLERANCE = 1e-9  # relative: rounding of the polynomial evaluation


@dataclass(frozen=True)
class MotionViolation:
    """The worst excess of one quantity in one segment of one joint."""

    joint: str
    segment: int  # index in the spline (0 is the lead-in when the first point is after the start)
    label: str  # 'segment 3 (point 2 -> point 3)', 'the lead-in to point 0'
    quantity: str  # position, velocity, acceleration
    value: float
    limit: float
    at: float  # s from the spline's first knot where it peaks

    def __str__(self) -> str:
        word = {'position': 'reaches', 'velocity': 'needs', 'acceleration': 'needs'}[self.quantity]
        limit = f'{"limit" if self.quantity != "position" else "position limit"} {self.limit:.6g}'
        return (f'{self.label}: {self.joint} {word} {self.quantity} {self.value:.6g} at {self.at:.4g} s, '
                f'beyond its {limit}')


def coefficient_matrix(durations: Array, start: tuple[Array, Array, Array], end: tuple[Array, Array, Array],
                       order: int) -> Array:
    """Coefficients (ascending powers) of every segment at once: order 1 linear, 3 cubic
    Hermite, 5 quintic; each row is what ``segment_coefficients`` gives for one segment."""
    p0, v0, a0 = start
    p1, v1, a1 = end
    T = durations
    if order == 1:
        return np.stack([p0, (p1 - p0) / T], axis=1)
    if order == 3:
        return np.stack([p0, v0, (3 * (p1 - p0) - (2 * v0 + v1) * T) / T ** 2,
                         (2 * (p0 - p1) + (v0 + v1) * T) / T ** 3], axis=1)
    return np.stack([p0, v0, a0 / 2,
                     (20 * (p1 - p0) - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T ** 2) / (2 * T ** 3),
                     (30 * (p0 - p1) + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T ** 2) / (2 * T ** 4),
                     (12 * (p1 - p0) - 6 * (v1 + v0) * T - (a0 - a1) * T ** 2) / (2 * T ** 5)], axis=1)


def _evaluate(c: Array, t: Array) -> tuple[Array, Array, Array]:
    """Position, velocity, acceleration of each row's polynomial at that row's instants."""
    n = c.shape[1]
    powers = [np.ones_like(t), t]
    for _ in range(2, n):
        powers.append(powers[-1] * t)
    position = sum(c[:, k:k + 1] * powers[k] for k in range(n))
    velocity = sum(k * c[:, k:k + 1] * powers[k - 1] for k in range(1, n))
    acceleration = (sum(k * (k - 1) * c[:, k:k + 1] * powers[k - 2] for k in range(2, n)) if n > 2
                    else np.zeros_like(t))
    return position, velocity, acceleration  # type: ignore[return-value]


def _instants(c: Array, durations: Array) -> Array:
    """Where each segment is evaluated: a linear one at its ends; a cubic at its ends and its
    exact extremes (the roots of its velocity, the vertex of its velocity; its acceleration is
    linear); a quintic at SAMPLES evenly spaced instants."""
    ends = np.stack([np.zeros_like(durations), durations], axis=1)
    if c.shape[1] == 2:
        return ends
    if c.shape[1] != 4:  # quintic: its acceleration's extremes exactly, where the jerk is 0
        even = durations[:, None] * np.linspace(0.0, 1.0, SAMPLES)[None, :]
        return np.concatenate([even, _quadratic_roots(6 * c[:, 3], 24 * c[:, 4], 60 * c[:, 5], durations)], axis=1)
    c1, c2, c3 = c[:, 1], 2 * c[:, 2], 3 * c[:, 3]  # velocity = c1 + c2 t + c3 t^2
    with np.errstate(divide='ignore', invalid='ignore'):
        vertex = np.where(c3 != 0, -c2 / (2 * c3), 0.0)  # the velocity's extreme
    vertex = np.clip(np.nan_to_num(vertex, nan=0.0, posinf=0.0, neginf=0.0), 0.0, durations)
    return np.concatenate([ends, vertex[:, None], _quadratic_roots(c1, c2, c3, durations)], axis=1)


def _quadratic_roots(c0: Array, c1: Array, c2: Array, durations: Array) -> Array:
    """The real roots of c0 + c1 t + c2 t^2 per row, clipped into [0, duration] (two columns)."""
    with np.errstate(divide='ignore', invalid='ignore'):
        root = np.sqrt(np.maximum(c1 * c1 - 4 * c2 * c0, 0.0))
        quadratic = c2 != 0
        r1 = np.where(quadratic, (-c1 + root) / (2 * c2), np.where(c1 != 0, -c0 / c1, 0.0))
        r2 = np.where(quadratic, (-c1 - root) / (2 * c2), 0.0)
    roots = np.stack([r1, r2], axis=1)
    clipped: Array = np.clip(np.nan_to_num(roots, nan=0.0, posinf=0.0, neginf=0.0), 0.0, durations[:, None])
    return clipped


@dataclass(frozen=True)
class SegmentPeaks:
    """Per segment of one joint: the extremes of its motion and where they occur."""

    lowest: Array
    highest: Array
    speed: Array  # the largest |velocity|
    accel: Array  # the largest |acceleration| (0 for linear segments)
    at_low: Array
    at_high: Array
    at_speed: Array
    at_accel: Array

    def rows(self, start: int, stop: int) -> SegmentPeaks:
        """The peaks of segments start..stop-1 (one joint's, of several evaluated at once)."""
        return SegmentPeaks(*(getattr(self, f)[start:stop] for f in (
            'lowest', 'highest', 'speed', 'accel', 'at_low', 'at_high', 'at_speed', 'at_accel')))


def segment_peaks(coefficients: Array, durations: Array) -> SegmentPeaks:
    with np.errstate(all='ignore'):  # huge values overflow to inf: a violation, not a warning
        t = _instants(coefficients, durations)
        position, velocity, acceleration = _evaluate(coefficients, t)
    speed, accel = np.abs(velocity), np.abs(acceleration)
    rows = np.arange(len(durations))
    lo, hi, sp, ac = (np.argmin(position, axis=1), np.argmax(position, axis=1), np.argmax(speed, axis=1),
                      np.argmax(accel, axis=1))
    return SegmentPeaks(position[rows, lo], position[rows, hi], speed[rows, sp], accel[rows, ac],
                        t[rows, lo], t[rows, hi], t[rows, sp], t[rows, ac])


def violations(joint: str, knots: Array, peaks: SegmentPeaks, limits: AxisLimits,
               label: Callable[[int], str]) -> tuple[list[MotionViolation], int]:
    """The first segment (in time) of one joint's spline (``knots``, its ``peaks``) beyond
    each of its limits, and how many segments are beyond any; ``label`` names a segment."""
    found: list[MotionViolation] = []
    count = 0
    checks: list[tuple[str, Array, Array, float | None, bool]] = [
        ('position', peaks.lowest, peaks.at_low, limits.min_position, True),
        ('position', peaks.highest, peaks.at_high, limits.max_position, False),
        ('velocity', peaks.speed, peaks.at_speed, limits.max_velocity, False),
        ('acceleration', peaks.accel, peaks.at_accel, limits.max_acceleration, False),
    ]
    for quantity, values, at, limit, below in checks:
        if limit is None:
            bad = ~np.isfinite(values)  # no limit, but never a motion that overflows
            limit = math.inf
        else:
            slack = TOLERANCE * max(1.0, abs(limit))
            bad = ~np.isfinite(values) | (values < limit - slack if below else values > limit + slack)
        if bad.any():
            count += int(np.count_nonzero(bad))
            i = int(np.argmax(bad))
            found.append(MotionViolation(joint, i, label(i), quantity, float(values[i]), limit,
                                         float(knots[i] + at[i])))
    return found, count


def stretch_factors(peaks_by_joint: Mapping[str, SegmentPeaks], limits: Mapping[str, AxisLimits],
                    count: int, accel_power: float = 0.5) -> Array:
    """By how much each segment's duration must grow (>= 1) so that no joint needs more than
    its velocity or acceleration limit: velocity falls with 1/factor, acceleration with
    1/factor^2 under a pure time scaling (``accel_power`` 0.5; a segment whose start state is
    fixed, the lead-in, falls slower: 1 there)."""
    factors = np.ones(count)
    for joint, peaks in peaks_by_joint.items():
        limit = limits[joint]
        if limit.max_velocity is not None:
            factors = np.maximum(factors, peaks.speed / limit.max_velocity)
        if limit.max_acceleration is not None:
            factors = np.maximum(factors, (peaks.accel / limit.max_acceleration) ** accel_power)
    return factors
