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

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from drive_bridge.joint.limits import unset_problem
from drive_bridge.model import AxisLimits
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.motion_check import coefficient_matrix


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


def _first(mask: npt.NDArray[np.bool_]) -> tuple[int, int]:
    """(point, joint) of the first True in a (points x joints) mask."""
    flat = int(np.argmax(mask))
    return divmod(flat, mask.shape[1]) if mask.ndim == 2 else (flat, 0)


def validate(trajectory: Trajectory, known: Mapping[str, AxisLimits], source: str = 'trajectory',
             waypoint_velocities: bool = True) -> TrajectoryArrays | None:
    """Refuse a trajectory that cannot be executed whole; each reason names the culprit.
    The per-value checks run on arrays (a 5,000-point trajectory in a few milliseconds); the
    motion between the points is checked once splined (``streaming.planning``).
    ``waypoint_velocities`` False: a waypoint velocity or acceleration beyond the limit is left
    to the motion check, which may stretch the trajectory (``trajectory.scale_to_limits``).
    Returns the trajectory as arrays (None for the empty one), for the planning to reuse."""
    joints = trajectory.joints
    if not trajectory.points:
        return None  # an empty trajectory is a stop request
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
    _check_shape(trajectory, source)
    data = TrajectoryArrays.of(trajectory)
    times = data.times
    bad_time = ~np.isfinite(times) | (times < 0)
    if bad_time.any():
        i = int(np.argmax(bad_time))
        raise TrajectoryError(f'{source}: point {i}: time_from_start {times[i]} must be finite and >= 0')
    steps = np.diff(times)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0)) + 1
        raise TrajectoryError(f'{source}: point {i}: time_from_start {times[i]:.6g} s is not after the previous '
                              f'point ({times[i - 1]:.6g} s); times must increase strictly')
    first = trajectory.points[0]
    arrays = {name: values for name, values, given in (
        ('position', data.positions, first.positions), ('velocity', data.velocities, first.velocities),
        ('acceleration', data.accelerations, first.accelerations)) if given and values is not None}
    for name, values in arrays.items():
        bad = ~np.isfinite(values)
        if bad.any():
            i, j = _first(bad)
            raise TrajectoryError(f'{source}: point {i}: {name} of {joints[j]} is {values[i, j]}')
    limits = [known[j] for j in joints]
    positions = arrays.get('position')
    if positions is not None:
        for bound, word, sign in (('min_position', 'below', -1.0), ('max_position', 'above', 1.0)):
            edge = np.array([getattr(lim, bound) if getattr(lim, bound) is not None else sign * np.inf
                             for lim in limits])
            bad = positions * sign > edge * sign
            if bad.any():
                i, j = _first(bad)
                raise TrajectoryError(f'{source}: point {i}: position {positions[i, j]:.6g} of {joints[j]} is '
                                      f'{word} its limit {edge[j]:.6g}')
    if waypoint_velocities:
        for name, key in (('velocity', 'max_velocity'), ('acceleration', 'max_acceleration')):
            at_points = arrays.get(name)
            if at_points is None:
                continue
            edge = np.array([getattr(lim, key) if getattr(lim, key) is not None else np.inf for lim in limits])
            bad = np.abs(at_points) > edge
            if bad.any():
                i, j = _first(bad)
                raise TrajectoryError(f'{source}: point {i}: {name} {at_points[i, j]:.6g} of {joints[j]} exceeds '
                                      f'its limit {edge[j]:.6g}')
    return data


def _check_shape(trajectory: Trajectory, source: str) -> None:
    """Every point has the same fields, each with one value per joint."""
    count = len(trajectory.joints)
    first = trajectory.points[0]
    shape = (bool(first.positions), bool(first.velocities), bool(first.accelerations))
    for i, point in enumerate(trajectory.points):
        where = f'{source}: point {i}'
        if point.positions and len(point.positions) != count:
            raise TrajectoryError(f'{where}: {len(point.positions)} positions for {count} joints')
        if not point.positions and not point.velocities:
            raise TrajectoryError(f'{where}: neither positions nor velocities')
        for name, values in (('velocities', point.velocities), ('accelerations', point.accelerations)):
            if values and len(values) != count:
                raise TrajectoryError(f'{where}: {len(values)} {name} for {count} joints')
        if point.accelerations and not point.velocities:
            raise TrajectoryError(f'{where}: accelerations given without velocities')
        here = (bool(point.positions), bool(point.velocities), bool(point.accelerations))
        if here != shape:
            if here[0] != shape[0]:
                raise TrajectoryError(f'{source}: some points have positions and others not; give positions in '
                                      'every point, or (velocity-only trajectory) in none')
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


@dataclass(frozen=True)
class SplineParts:
    """One joint's spline as arrays: ``knots`` (s from its start), ``matrix`` (one row of
    coefficients per segment, ascending powers), the states at the first and last knot."""

    knots: npt.NDArray[np.float64]
    matrix: npt.NDArray[np.float64]
    first: JointSample
    last: JointSample
    lead_in: bool  # the first segment runs from the start state to the first waypoint


def spline_parts(start: JointSample, times: npt.NDArray[np.float64], states: npt.NDArray[np.float64],
                 order: int) -> SplineParts:
    """The segments from ``start`` through waypoints at ``times`` (n,) with ``states``
    (n x 3: position, velocity, acceleration), all coefficients computed at once."""
    first = np.array([[start.position, start.velocity, start.acceleration]])
    knots = np.concatenate([[0.0], times])
    all_states = np.concatenate([first, states])
    lead_in = not (len(times) and times[0] <= 0.0)  # else no segment before the first waypoint
    if not lead_in:
        knots, all_states = knots[1:], all_states[1:]
    if len(knots) > 1:
        matrix = coefficient_matrix(np.diff(knots), (all_states[:-1, 0], all_states[:-1, 1], all_states[:-1, 2]),
                                    (all_states[1:, 0], all_states[1:, 1], all_states[1:, 2]), order)
    else:
        matrix = np.zeros((0, order + 1))
    head, tail = all_states[0].tolist(), all_states[-1].tolist()
    return SplineParts(knots, matrix, JointSample(*head), JointSample(*tail), lead_in)


class JointSpline:
    """One joint's path from a start state through waypoints; holds the last point after.

    ``parts`` keeps the arrays (what the motion check evaluates); ``knots`` as a list and each
    segment's coefficients converted when first sampled keep the per-cycle ``sample`` cheap."""

    def __init__(self, start_time: float, start: JointSample, times: Sequence[float],
                 samples: Sequence[JointSample], order: int) -> None:
        states = np.array([(s.position, s.velocity, s.acceleration) for s in samples],
                          dtype=np.float64).reshape(-1, 3)
        self._build(start_time, spline_parts(start, np.asarray(times, dtype=np.float64), states, order))

    @classmethod
    def of_parts(cls, start_time: float, parts: SplineParts) -> JointSpline:
        spline = cls.__new__(cls)
        spline._build(start_time, parts)
        return spline

    def _build(self, start_time: float, parts: SplineParts) -> None:
        self.start_time = start_time
        self.parts = parts
        self.lead_in = parts.lead_in
        self.first, self.last = parts.first, parts.last
        self.knots: list[float] = parts.knots.tolist()
        self._rows: dict[int, list[float]] = {}
        self.end_time = start_time + self.knots[-1]

    def sample(self, t: float) -> JointSample:
        local = t - self.start_time
        if local <= self.knots[0]:
            first = self.first
            return JointSample(first.position, 0.0, 0.0) if local < self.knots[0] else first
        if local >= self.knots[-1]:
            return JointSample(self.last.position, 0.0, 0.0)
        lo, hi = 0, len(self.knots) - 1  # binary search for the segment
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if self.knots[mid] <= local:
                lo = mid
            else:
                hi = mid
        row = self._rows.get(lo)
        if row is None:
            if len(self._rows) > 64:
                self._rows.clear()
            row = self._rows[lo] = self.parts.matrix[lo].tolist()
        return _poly(local - self.knots[lo], row)


def order_of(trajectory: Trajectory) -> int:
    first = trajectory.points[0]
    return 5 if first.accelerations else 3 if first.velocities else 1


def has_positions(trajectory: Trajectory) -> bool:
    return bool(trajectory.points) and bool(trajectory.points[0].positions)


def integrated_positions(velocities: npt.NDArray[np.float64], times: npt.NDArray[np.float64],
                         start: float) -> npt.NDArray[np.float64]:
    """Positions at the points of a velocity-only trajectory: the velocities integrated from
    ``start`` at time 0 from rest (trapezoidal, exact for the cubic through them when the
    velocity is linear between points)."""
    previous_v = np.concatenate([[0.0], velocities[:-1]])
    previous_t = np.concatenate([[0.0], times[:-1]])
    return start + np.cumsum((previous_v + velocities) / 2 * (times - previous_t))


@dataclass(frozen=True)
class TrajectoryArrays:
    """A validated, non-empty trajectory as arrays: ``times`` (n,), ``positions`` (n x joints,
    None for a velocity-only one), ``velocities`` and ``accelerations`` (zeros where not given)."""

    joints: tuple[str, ...]
    times: npt.NDArray[np.float64]
    positions: npt.NDArray[np.float64] | None
    velocities: npt.NDArray[np.float64]
    accelerations: npt.NDArray[np.float64]
    order: int

    @classmethod
    def of(cls, trajectory: Trajectory) -> TrajectoryArrays:
        points = trajectory.points
        zeros = np.zeros((len(points), len(trajectory.joints)))
        first = points[0]
        return cls(trajectory.joints, np.array([p.time for p in points], dtype=np.float64),
                   np.array([p.positions for p in points], dtype=np.float64) if first.positions else None,
                   np.array([p.velocities for p in points], dtype=np.float64) if first.velocities else zeros,
                   np.array([p.accelerations for p in points], dtype=np.float64) if first.accelerations else zeros,
                   order_of(trajectory))

    def tail(self, dropped: int, elapsed: float) -> TrajectoryArrays:
        """Without the first ``dropped`` points, the others ``elapsed`` s earlier."""
        if not dropped and not elapsed:
            return self
        return TrajectoryArrays(self.joints, self.times[dropped:] - elapsed,
                                None if self.positions is None else self.positions[dropped:],
                                self.velocities[dropped:], self.accelerations[dropped:], self.order)

    def parts(self, j: int, start: JointSample, times: npt.NDArray[np.float64] | None = None) -> SplineParts:
        """Joint ``j``'s spline from ``start``, at the points' ``times`` (or others: stretched)."""
        times = self.times if times is None else times
        column = (self.positions[:, j] if self.positions is not None
                  else integrated_positions(self.velocities[:, j], times, start.position))
        states = np.stack([column, self.velocities[:, j], self.accelerations[:, j]], axis=1)
        return spline_parts(start, times, states, self.order)


def joint_splines(trajectory: Trajectory, start_time: float,
                  start_states: Mapping[str, JointSample]) -> dict[str, JointSpline]:
    """One spline per joint of a validated, non-empty trajectory."""
    arrays = TrajectoryArrays.of(trajectory)
    return {joint: JointSpline.of_parts(start_time, arrays.parts(j, start_states[joint]))
            for j, joint in enumerate(trajectory.joints)}
