"""Trajectory model: joint_trajectory_controller interpolation rules and whole-trajectory validation."""
from __future__ import annotations

import math

import pytest

from drive_bridge.model import AxisLimits
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.trajectory import (
    JointSample,
    Trajectory,
    TrajectoryPoint,
    joint_splines,
    validate,
)

LIMITS = {'a': AxisLimits(min_position=-1.0, max_position=1.0, max_velocity=2.0), 'b': AxisLimits()}
REST = JointSample(0.0, 0.0, 0.0)


def spline(points: list[TrajectoryPoint], start: JointSample = REST, joint: str = 'a'):
    trajectory = Trajectory((joint,), tuple(points))
    validate(trajectory, LIMITS)
    return joint_splines(trajectory, 100.0, {joint: start})[joint]


def test_positions_only_interpolate_linearly_from_the_start_state() -> None:
    s = spline([TrajectoryPoint(1.0, (0.5,)), TrajectoryPoint(2.0, (-0.5,))])
    assert s.sample(100.5).position == pytest.approx(0.25)
    assert s.sample(101.5).position == pytest.approx(0.0)
    assert s.sample(101.5).velocity == pytest.approx(-1.0)
    assert s.sample(99.0).position == 0.0 and s.sample(105.0) == JointSample(-0.5, 0.0, 0.0)


def test_velocities_give_a_cubic_that_meets_both_ends() -> None:
    s = spline([TrajectoryPoint(1.0, (0.5,), (1.0,)), TrajectoryPoint(2.0, (0.8,), (0.0,))],
               start=JointSample(0.1, 0.3, 0.0))
    assert s.sample(100.0).position == pytest.approx(0.1) and s.sample(100.0).velocity == pytest.approx(0.3)
    assert s.sample(101.0 - 1e-9).position == pytest.approx(0.5)
    assert s.sample(101.0 + 1e-9).velocity == pytest.approx(1.0, abs=1e-6)
    assert s.sample(102.0 - 1e-9).velocity == pytest.approx(0.0, abs=1e-6)


def test_accelerations_give_a_quintic_that_meets_position_velocity_and_acceleration() -> None:
    s = spline([TrajectoryPoint(2.0, (1.0,), (0.0,), (0.0,))])
    assert s.sample(101.0).position == pytest.approx(0.5)  # symmetric minimum-jerk
    assert s.sample(101.0).velocity == pytest.approx(15 / 16)  # 1.875 * distance / T
    assert s.sample(100.0).acceleration == pytest.approx(0.0)
    assert s.sample(102.0 - 1e-9).acceleration == pytest.approx(0.0, abs=1e-6)


def test_first_point_at_time_zero_has_no_lead_in() -> None:
    s = spline([TrajectoryPoint(0.0, (0.2,)), TrajectoryPoint(1.0, (0.4,))], start=JointSample(0.9, 0, 0))
    assert s.sample(100.0).position == pytest.approx(0.2)


@pytest.mark.parametrize('trajectory, message', [
    (Trajectory(('a', 'x'), (TrajectoryPoint(1, (0, 0)),)), 'unknown joint(s) x'),
    (Trajectory(('a', 'a'), (TrajectoryPoint(1, (0, 0)),)), 'listed twice: a'),
    (Trajectory(('a',), (TrajectoryPoint(1, (0,)), TrajectoryPoint(1, (0.1,)))),
     'point 1: time_from_start 1 s is not after the previous point (1 s)'),
    (Trajectory(('a',), (TrajectoryPoint(1, (math.nan,)),)), 'point 0: position of a is nan'),
    (Trajectory(('a', 'b'), (TrajectoryPoint(1, (0.0,)),)), 'point 0: 1 positions for 2 joints'),
    (Trajectory(('a',), (TrajectoryPoint(1, (0.0,), (1.0, 2.0)),)), 'point 0: 2 velocities for 1 joints'),
    (Trajectory(('a',), (TrajectoryPoint(1, (1.5,)),)), 'point 0: position 1.5 of a is above its limit 1'),
    (Trajectory(('a',), (TrajectoryPoint(1, (0.0,), (3.0,)),)), 'velocity 3 of a exceeds its limit 2'),
    (Trajectory(('a',), (TrajectoryPoint(1, (0.0,), (), (1.0,)),)), 'accelerations given without velocities'),
    (Trajectory(('a',), (TrajectoryPoint(1, (0.0,), (0.0,)), TrajectoryPoint(2, (0.1,)))),
     'some points have velocities'),
    (Trajectory(('a',), (TrajectoryPoint(-1, (0.0,)),)), 'must be finite and >= 0'),
])
def test_bad_trajectories_are_refused_with_the_reason(trajectory: Trajectory, message: str) -> None:
    with pytest.raises(TrajectoryError) as error:
        validate(trajectory, LIMITS, '~/joint_trajectory')
    assert message in str(error.value) and str(error.value).startswith('~/joint_trajectory: ')


def test_velocity_only_points_are_integrated_from_the_start_position() -> None:
    from drive_bridge.streaming.trajectory import JointSample, joint_splines
    trajectory = Trajectory(('j',), (TrajectoryPoint(1.0, (), (1.0,)), TrajectoryPoint(2.0, (), (0.0,))))
    validate(trajectory, {'j': AxisLimits()})
    spline = joint_splines(trajectory, 10.0, {'j': JointSample(5.0, 0.0, 0.0)})['j']
    assert spline.sample(11.0).position == pytest.approx(5.5)  # (0 + 1) / 2 * 1 s
    assert spline.sample(12.0).position == pytest.approx(6.0)
    assert spline.sample(11.0).velocity == pytest.approx(1.0)
    mixed = Trajectory(('j',), (TrajectoryPoint(1.0, (0.0,), (1.0,)), TrajectoryPoint(2.0, (), (0.0,))))
    with pytest.raises(TrajectoryError, match='some points have positions and others not'):
        validate(mixed, {'j': AxisLimits()})
