"""Joint trajectories in the core: the data, its validation, and per-joint splines.

Interpolation follows joint_trajectory_controller: positions only -> linear; with
velocities -> cubic Hermite; with velocities and accelerations -> quintic. Points with
velocities and no positions (for velocity-commanded joints) get their positions by
integrating the velocities from the start state, as joint_trajectory_controller does with
``allow_integration_in_goal_trajectories``. A trajectory
whose first point is later than its start begins from the joint's current desired state
(position, velocity, acceleration) at the start time, which is also how a replacement
splices into a running trajectory.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint.limits import unset_problem
from drive_bridge.model import AxisLimits


@dataclass(frozen=True)
class TrajectoryPoint:
    """One waypoint; ``time`` is seconds from the trajectory start."""

    time: float
    positions: tuple[float, ...]
    velocities: tuple[float, ...] = ()
    accelerations: tuple[float, ...] = ()


@dataclass(frozen=True)
class Trajectory:
    """A multi-joint trajectory; ``start`` is an epoch time, None = when received."""

    joints: tuple[str, ...]
    points: tuple[TrajectoryPoint, ...]
    start: float | None = None


@dataclass(frozen=True)
class JointSample:
    position: float
    velocity: float
    acceleration: float


# Points in one trajectory: bounds the work (and the GIL time) of converting, validating and
# splining a client's message. At a 4 ms cycle, 5000 points are 20 s streamed point by point.
MAX_TRAJECTORY_POINTS = 5000


class TrajectoryError(DriveBridgeError, ValueError):
    """A trajectory refused as a whole; the message says why."""


def validate(trajectory: Trajectory, known: Mapping[str, AxisLimits], source: str = 'trajectory') -> None:
    """Refuse a trajectory that cannot be executed whole; each reason names the culprit."""
    joints = trajectory.joints
    if not trajectory.points:
        return  # an empty trajectory is a stop request
    if len(trajectory.points) > MAX_TRAJECTORY_POINTS:  # first: the work below grows with it
        raise TrajectoryError(f'{source}: {len(trajectory.points)} points, more than the limit of '
                              f'{MAX_TRAJECTORY_POINTS}')
    unknown = [j for j in joints if j not in known]
    if unknown:
        raise TrajectoryError(f'{source}: unknown joint(s) {", ".join(unknown)}; this bus has {", ".join(known)}')
    duplicates = sorted({j for j in joints if joints.count(j) > 1})
    if duplicates:
        raise TrajectoryError(f'{source}: joint(s) listed twice: {", ".join(duplicates)}')
    for joint in joints:
        if known[joint].todo:
            raise TrajectoryError(f'{source}: joint {joint} is {unset_problem(known[joint])}')
    previous = -math.inf
    for i, point in enumerate(trajectory.points):
        where = f'{source}: point {i}'
        if not math.isfinite(point.time) or point.time < 0:
            raise TrajectoryError(f'{where}: time_from_start {point.time} must be finite and >= 0')
        if point.time <= previous:
            raise TrajectoryError(f'{where}: time_from_start {point.time:.6g} s is not after the previous '
                                  f'point ({previous:.6g} s); times must increase strictly')
        previous = point.time
        if point.positions and len(point.positions) != len(joints):
            raise TrajectoryError(f'{where}: {len(point.positions)} positions for {len(joints)} joints')
        if not point.positions and not point.velocities:
            raise TrajectoryError(f'{where}: neither positions nor velocities')
        for name, values in (('velocities', point.velocities), ('accelerations', point.accelerations)):
            if values and len(values) != len(joints):
                raise TrajectoryError(f'{where}: {len(values)} {name} for {len(joints)} joints')
        if point.accelerations and not point.velocities:
            raise TrajectoryError(f'{where}: accelerations given without velocities')
        for name, values in (('position', point.positions), ('velocity', point.velocities),
                             ('acceleration', point.accelerations)):
            for joint, value in zip(joints, values):
                if not math.isfinite(value):
                    raise TrajectoryError(f'{where}: {name} of {joint} is {value}')
        for joint, position in zip(joints, point.positions):
            limits = known[joint]
            if limits.min_position is not None and position < limits.min_position:
                raise TrajectoryError(f'{where}: position {position:.6g} of {joint} is below its limit '
                                      f'{limits.min_position:.6g}')
            if limits.max_position is not None and position > limits.max_position:
                raise TrajectoryError(f'{where}: position {position:.6g} of {joint} is above its limit '
                                      f'{limits.max_position:.6g}')
        for joint, velocity in zip(joints, point.velocities):
            limit = known[joint].max_velocity
            if limit is not None and abs(velocity) > limit:
                raise TrajectoryError(f'{where}: velocity {velocity:.6g} of {joint} exceeds its limit {limit:.6g}')
    if len({bool(p.positions) for p in trajectory.points}) > 1:
        raise TrajectoryError(f'{source}: some points have positions and others not; give positions in every '
                              'point, or (velocity-only trajectory) in none')
    kinds = {(bool(p.velocities), bool(p.accelerations)) for p in trajectory.points}
    if len(kinds) > 1:
        raise TrajectoryError(f'{source}: some points have velocities/accelerations and others not; '
                              'give the same fields in every point')


def _poly(t: float, c: Sequence[float]) -> JointSample:
    """Sample a polynomial with coefficients c (ascending powers)."""
    position = velocity = acceleration = 0.0
    for power in range(len(c) - 1, -1, -1):
        position = position * t + c[power]
    for power in range(len(c) - 1, 0, -1):
        velocity = velocity * t + power * c[power]
    for power in range(len(c) - 1, 1, -1):
        acceleration = acceleration * t + power * (power - 1) * c[power]
    return JointSample(position, velocity, acceleration)


def segment_coefficients(duration: float, start: JointSample, end: JointSample, order: int) -> tuple[float, ...]:
    """Polynomial coefficients over [0, duration]: order 1 linear, 3 cubic Hermite, 5 quintic."""
    p0, v0, a0 = start.position, start.velocity, start.acceleration
    p1, v1, a1 = end.position, end.velocity, end.acceleration
    T = duration
    if order == 1:
        return (p0, (p1 - p0) / T)
    if order == 3:
        return (p0, v0, (3 * (p1 - p0) - (2 * v0 + v1) * T) / T ** 2, (2 * (p0 - p1) + (v0 + v1) * T) / T ** 3)
    return (p0, v0, a0 / 2,
            (20 * (p1 - p0) - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T ** 2) / (2 * T ** 3),
            (30 * (p0 - p1) + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T ** 2) / (2 * T ** 4),
            (12 * (p1 - p0) - 6 * (v1 + v0) * T - (a0 - a1) * T ** 2) / (2 * T ** 5))


class JointSpline:
    """One joint's path from a start state through waypoints; holds the last point after."""

    def __init__(self, start_time: float, start: JointSample, times: Sequence[float],
                 samples: Sequence[JointSample], order: int) -> None:
        self.start_time = start_time
        knots = [0.0, *times]
        states = [start, *samples]
        if times and times[0] <= 0.0:  # the first waypoint is at the start: no lead-in segment
            knots, states = knots[1:], states[1:]
        self.knots = knots
        self.states = states
        self.coefficients = [segment_coefficients(knots[i + 1] - knots[i], states[i], states[i + 1], order)
                             for i in range(len(knots) - 1)]
        self.end_time = start_time + knots[-1]

    def sample(self, t: float) -> JointSample:
        local = t - self.start_time
        if local <= self.knots[0]:
            first = self.states[0]
            return JointSample(first.position, 0.0, 0.0) if local < self.knots[0] else first
        if local >= self.knots[-1]:
            return JointSample(self.states[-1].position, 0.0, 0.0)
        lo, hi = 0, len(self.knots) - 1  # binary search for the segment
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if self.knots[mid] <= local:
                lo = mid
            else:
                hi = mid
        return _poly(local - self.knots[lo], self.coefficients[lo])


def order_of(trajectory: Trajectory) -> int:
    first = trajectory.points[0]
    return 5 if first.accelerations else 3 if first.velocities else 1


def has_positions(trajectory: Trajectory) -> bool:
    return bool(trajectory.points) and bool(trajectory.points[0].positions)


def integrated_positions(trajectory: Trajectory, j: int, start: float) -> list[float]:
    """Positions of joint ``j`` at the points of a velocity-only trajectory: the velocities
    integrated from ``start`` at time 0 (trapezoidal, exact for the cubic through them when
    the velocity is linear between points)."""
    positions, position, time, velocity = [], start, 0.0, 0.0
    for point in trajectory.points:
        position += (velocity + point.velocities[j]) / 2 * (point.time - time)
        time, velocity = point.time, point.velocities[j]
        positions.append(position)
    return positions


def joint_splines(trajectory: Trajectory, start_time: float,
                  start_states: Mapping[str, JointSample]) -> dict[str, JointSpline]:
    """One spline per joint of a validated, non-empty trajectory."""
    order = order_of(trajectory)
    times = [p.time for p in trajectory.points]
    splines = {}
    for j, joint in enumerate(trajectory.joints):
        start = start_states[joint]
        positions = ([p.positions[j] for p in trajectory.points] if has_positions(trajectory)
                     else integrated_positions(trajectory, j, start.position))
        samples = [JointSample(position, p.velocities[j] if p.velocities else 0.0,
                               p.accelerations[j] if p.accelerations else 0.0)
                   for position, p in zip(positions, trajectory.points)]
        splines[joint] = JointSpline(start_time, start, times, samples, order)
    return splines
