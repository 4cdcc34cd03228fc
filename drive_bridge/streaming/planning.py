"""From a validated trajectory to the splines the executor streams: the part of a stamp in
the past dropped, the motion between every pair of points checked against the joints'
limits, and (``trajectory.scale_to_limits``) segments stretched in time where it is not.

Past stamps follow joint_trajectory_controller: the points whose time is already over are
dropped and the motion starts now from the joint's current state (a running trajectory's
desired state, else the position the drive holds, at rest), blended into the first future
point by the lead-in segment of the executor's interpolation; the lead-in is checked like
every other segment, so a first future point that cannot be reached in time within the
limits refuses the trajectory (or, with scale_to_limits, is reached later). No set-point
step larger than the limits allow in one cycle is ever planned.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from drive_bridge.model import AxisLimits
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.motion_check import (
    MotionViolation,
    SegmentPeaks,
    segment_peaks,
    stretch_factors,
    violations,
)
from drive_bridge.streaming.trajectory import (
    JointSample,
    JointSpline,
    SplineParts,
    Trajectory,
    TrajectoryArrays,
)

STRETCH_ROUNDS = 8  # a stretched cubic with given waypoint velocities converges in two or three
STRETCH_MARGIN = 1.02  # stretch a little more than the peak asks: the next round then passes
PER_SEGMENT_ROUNDS = 3  # then the whole trajectory is slowed uniformly (a dense one ripples otherwise)


@dataclass(frozen=True)
class Plan:
    """What the executor runs: the splines from ``start`` (epoch s) and what was changed."""

    start: float
    duration: float  # s, as it runs (stretched)
    splines: dict[str, JointSpline]
    notes: tuple[str, ...] = ()  # what was changed: points dropped, segments stretched (the result says so)
    dropped: int = 0  # points already past at submission
    warnings: tuple[str, ...] = ()  # what could not be checked (a joint without a velocity limit)


def drop_past(trajectory: Trajectory, start: float, now: float) -> tuple[Trajectory, float, int]:
    """The points already over dropped and the rest timed from ``now``; (trajectory, start,
    points dropped). A trajectory that ends in the past is for the caller to refuse."""
    if start >= now:
        return trajectory, start, 0
    elapsed = now - start
    kept = [p for p in trajectory.points if p.time > elapsed]
    dropped = len(trajectory.points) - len(kept)
    points = tuple(replace(p, time=p.time - elapsed) for p in kept)
    return replace(trajectory, points=points, start=now), now, dropped


def _labeller(lead_in: bool, offset: int) -> Callable[[int], str]:
    """Segment names in the client's point numbering (``offset``: points dropped before)."""
    def label(i: int) -> str:
        point = i + offset + (0 if lead_in else 1)
        return (f'the lead-in from the current state to point {offset}' if lead_in and i == 0
                else f'segment point {point - 1} -> point {point}')
    return label


def _stretched(times: np.ndarray, factors: np.ndarray, lead_in: bool) -> np.ndarray:
    """Point times with each segment's duration multiplied by its factor (``lead_in``: the
    first factor is the segment from the start to the first point)."""
    knots = np.concatenate([[0.0], times]) if lead_in else times
    new_knots = np.concatenate([[knots[0]], knots[0] + np.cumsum(np.diff(knots) * factors)])
    return new_knots[1:] if lead_in else new_knots


def _peaks(parts: Mapping[str, SplineParts]) -> dict[str, SegmentPeaks]:
    """Every joint's segment peaks, evaluated in one batch (the joints share their knots)."""
    moving = {joint: part for joint, part in parts.items() if len(part.matrix)}
    if not moving:
        return {}
    first = next(iter(moving.values()))
    count = len(first.matrix)
    peaks = segment_peaks(np.concatenate([p.matrix for p in moving.values()]),
                          np.tile(np.diff(first.knots), len(moving)))
    return {joint: peaks.rows(i * count, (i + 1) * count) for i, joint in enumerate(moving)}


def _slowed(arrays: TrajectoryArrays, factors: np.ndarray, lead_in: bool) -> TrajectoryArrays:
    """Waypoint velocities and accelerations as a time scaling by the larger factor of the
    two segments meeting there leaves them (1/f, 1/f^2): the path keeps its shape."""
    ones = np.ones(1)
    before = factors if lead_in else np.concatenate([ones, factors])  # the segment ending at each point
    after = np.concatenate([factors[1:], ones]) if lead_in else np.concatenate([factors, ones])
    at_point = np.maximum(before, after)[:, None]
    return replace(arrays, velocities=arrays.velocities / at_point, accelerations=arrays.accelerations / at_point ** 2)


def unlimited_notes(joints: Sequence[str], limits: Mapping[str, AxisLimits]) -> list[str]:
    return [f'joint {j} has no velocity limit (limits.max_velocity not set and the drive reported none): '
            'the speed of its motion is not checked' for j in joints if limits[j].max_velocity is None]


def plan(trajectory: Trajectory, start: float, now: float, states: Callable[[float], Mapping[str, JointSample]],
         limits: Mapping[str, AxisLimits], scale_to_limits: bool, source: str, not_before: float = 0.0,
         arrays: TrajectoryArrays | None = None) -> Plan:
    """Splines for a validated, non-empty trajectory; TrajectoryError names the segment,
    the joint and the figure of the first violation (or why it ends in the past).
    ``not_before``: the earliest start (a PVT stream committed to the drive until then);
    ``arrays``: the trajectory as ``validate`` returned it (else converted here)."""
    original_end = start + trajectory.points[-1].time
    if original_end < now:
        raise TrajectoryError(f'{source}: ends {now - original_end:.3f} s in the past (header.stamp too old)')
    elapsed = max(0.0, now - start)
    trajectory, start, dropped = drop_past(trajectory, start, now)
    if not_before > start:
        trajectory, start = replace(trajectory, start=not_before), not_before
    notes = []
    if dropped:
        notes.append(f'{dropped} point(s) already past (header.stamp {elapsed:.3f} s old) dropped; the motion '
                     'starts now from the current state')
    warnings = tuple(unlimited_notes(trajectory.joints, limits))
    start_states = states(start)
    # the trajectory as it runs: ``trajectory`` is already without its past; the given arrays are not
    arrays = TrajectoryArrays.of(trajectory) if arrays is None else arrays.tail(dropped, elapsed)
    times = arrays.times
    for _round in range(STRETCH_ROUNDS):
        parts = {joint: arrays.parts(j, start_states[joint], times) for j, joint in enumerate(trajectory.joints)}
        found: list[MotionViolation] = []
        count = 0
        peaks = _peaks(parts)
        for joint, part in parts.items():
            if joint not in peaks:
                continue
            first_ones, n = violations(joint, part.knots, peaks[joint], limits[joint],
                                       _labeller(part.lead_in, dropped))
            found += first_ones
            count += n
        if not found:
            duration = float(times[-1])
            if duration > float(arrays.times[-1]) + 1e-12:
                notes.append(f"stretched to the joints' limits (trajectory.scale_to_limits): {duration:.4g} s "
                             f'instead of {float(arrays.times[-1]):.4g} s')
            splines = {joint: JointSpline.of_parts(start, part) for joint, part in parts.items()}
            return Plan(start, duration, splines, tuple(notes), dropped, warnings)
        found.sort(key=lambda v: (v.quantity != 'position', v.segment))
        worst = found[0]
        more = f' (and {count - 1} more violation(s))' if count > 1 else ''
        if not scale_to_limits or worst.quantity == 'position' or not math.isfinite(worst.value):
            cure = ('; time cannot cure a position excess: change the points or their velocities'
                    if worst.quantity == 'position' and scale_to_limits else
                    '' if worst.quantity == 'position' else
                    '; slow it down, or set trajectory.scale_to_limits to stretch it')
            raise TrajectoryError(f'{source}: {worst}{more}{cure}')
        lead_in = next(iter(parts.values())).lead_in
        factors = stretch_factors(peaks, limits, len(times) - (0 if lead_in else 1), 0.5 if _round == 0 else 1.0)
        factors = np.where(factors > 1.0, factors * STRETCH_MARGIN, 1.0)
        if _round >= PER_SEGMENT_ROUNDS:  # neighbours stretched unevenly ripple: scale it all at once
            factors = np.full_like(factors, factors.max())
        times = _stretched(times, factors, lead_in)
        arrays = _slowed(arrays, factors, lead_in)
    raise TrajectoryError(f'{source}: {worst}; not within the limits after stretching it {STRETCH_ROUNDS} times')
