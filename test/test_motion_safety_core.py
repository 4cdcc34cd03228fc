"""The motion checks in the core (what the bus process runs beside the cycle): the planner's
segment check, its stretching and past stamps, on plain data; the drive's own limits read at
boot; the cycle check's quick-stop reaction and its PVT-point check, on simulated drives."""
from __future__ import annotations

import math
import time

import pytest
import yaml

from bustools import DEMO, config_from, demo_data, eventually, running, unique_channel
from drive_bridge.cia402.drive_limits import describe
from drive_bridge.cia402.statemachine import State
from drive_bridge.joint import Setpoint
from drive_bridge.master.events import EventKind
from drive_bridge.model import AxisLimits
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.planning import plan
from drive_bridge.streaming.trajectory import JointSample, Trajectory, TrajectoryPoint, validate

LIMITS = {'j': AxisLimits(-3.1, 3.1, 2.0, 10.0)}
AKD_EXAMPLE = DEMO.parent / 'akd_pvt_example.yaml'


def at(position: float) -> dict[str, JointSample]:
    return {'j': JointSample(position, 0.0, 0.0)}


def planned(points: list[TrajectoryPoint], start: float = 100.0, now: float = 100.0, here: float = 0.0,
            scale: bool = False) -> object:
    trajectory = Trajectory(('j',), tuple(points))
    return plan(trajectory, start, now, lambda _t: at(here), LIMITS, scale, 'test',
                arrays=validate(trajectory, LIMITS, 'test', waypoint_velocities=not scale))


def test_a_cubic_overshoot_between_in_limit_points_is_refused_naming_segment_joint_and_figure() -> None:
    with pytest.raises(TrajectoryError, match=r'segment point 0 -> point 1: j reaches position 3.59259 at 4.333 s, '
                                              r'beyond its position limit 3.1'):
        planned([TrajectoryPoint(3.0, (3.0,), (0.0,)), TrajectoryPoint(5.0, (3.0,), (-2.0,)),
                 TrajectoryPoint(9.0, (0.0,), (0.0,))], here=3.0)


def test_acceleration_between_points_is_checked_and_a_quintic_too() -> None:
    with pytest.raises(TrajectoryError, match=r'j needs acceleration .* beyond its limit 10'):
        planned([TrajectoryPoint(0.5, (0.5,), (0.0,))])  # rest to rest, 0.5 rad in 0.5 s: 1.5 rad/s, 12 rad/s^2
    with pytest.raises(TrajectoryError, match=r'j needs (velocity|acceleration) .* beyond its limit'):
        planned([TrajectoryPoint(0.4, (1.0,), (0.0,), (0.0,))])


def test_scale_to_limits_stretches_the_motion_until_it_keeps_every_limit() -> None:
    result = planned([TrajectoryPoint(0.001, (0.0,)), TrajectoryPoint(0.002, (2.5,))], scale=True)
    assert any('stretched' in note for note in result.notes)  # type: ignore[attr-defined]
    spline = result.splines['j']  # type: ignore[attr-defined]
    samples = [spline.sample(100.0 + k * 0.004) for k in range(int(result.duration / 0.004) + 2)]  # type: ignore[attr-defined]
    steps = [abs(b.position - a.position) for a, b in zip(samples, samples[1:])]
    assert max(steps) <= 2.0 * 0.004 * 1.0001 and samples[-1].position == pytest.approx(2.5)
    cubic = planned([TrajectoryPoint(0.2, (1.0,), (0.0,))], scale=True)
    peaks = [cubic.splines['j'].sample(100.0 + k * 0.001) for k in range(2000)]  # type: ignore[attr-defined]
    assert max(abs(p.velocity) for p in peaks) <= 2.0 + 1e-6 and max(abs(p.acceleration) for p in peaks) <= 10.0 + 1e-6
    with pytest.raises(TrajectoryError, match='time cannot cure a position excess'):
        planned([TrajectoryPoint(3.0, (3.0,), (0.0,)), TrajectoryPoint(5.0, (3.0,), (-2.0,)),
                 TrajectoryPoint(9.0, (0.0,), (0.0,))], here=3.0, scale=True)


def test_a_past_stamp_drops_the_points_over_and_blends_from_the_current_state() -> None:
    result = planned([TrajectoryPoint(3.0, (1.0,)), TrajectoryPoint(6.0, (1.67,))], start=95.0)
    assert result.dropped == 1 and result.start == 100.0  # type: ignore[attr-defined]
    first = result.splines['j'].sample(100.004)  # type: ignore[attr-defined]
    assert first.position == pytest.approx(1.67 * 0.004, rel=1e-6)  # 1.67 rad in the 1 s left: no jump
    with pytest.raises(TrajectoryError, match='needs velocity 4.175'):  # 1.67 rad in 0.4 s: beyond 2 rad/s
        planned([TrajectoryPoint(3.0, (1.0,)), TrajectoryPoint(5.4, (1.67,))], start=95.0)
    with pytest.raises(TrajectoryError, match='in the past'):
        planned([TrajectoryPoint(3.0, (1.0,))], start=95.0)


def test_a_huge_value_overflows_into_a_refusal_not_a_pass() -> None:
    with pytest.raises(TrajectoryError, match=r'point 0: acceleration 1e\+300 of j exceeds its limit 10'):
        planned([TrajectoryPoint(1.0, (0.1,), (0.0,), (1e300,))])  # named at the waypoint
    with pytest.raises(TrajectoryError, match=r'j (reaches|needs) .* beyond its'):  # stretching cannot cure it
        planned([TrajectoryPoint(1.0, (0.1,), (0.0,), (1e300,))], scale=True)


def test_the_drives_own_limits_fill_what_the_config_leaves_out_and_are_said_once() -> None:
    with running(config_from(demo_data())) as (master, _sim):
        limits = master.axes['base_joint'].config.limits
        assert limits.max_velocity == 2.0 and limits.sources['max_velocity'] == 'config'
        # 0x60C5 = 2,000,000 counts/s^2, 65536 counts per revolution, gear 10
        assert limits.max_acceleration == pytest.approx(2_000_000 * 2 * math.pi / 65536 / 10)
        assert limits.sources['max_acceleration'] == 'drive 0x60C5'
        said = [e.message for e in master.events if 'joint base_joint: limits checked' in e.message]
        assert len(said) == 1 and 'acceleration 19.1748 (drive 0x60C5)' in said[0]


def test_a_joint_without_a_velocity_limit_is_said_at_start_and_with_each_trajectory_naming_the_key() -> None:
    unlimited = {'j': AxisLimits(-3.1, 3.1, None, 10.0)}
    assert 'no velocity limit (limits.max_velocity not set' in describe('j', unlimited['j'])
    assert 'no velocity limit' not in describe('j', LIMITS['j'])
    trajectory = Trajectory(('j',), (TrajectoryPoint(1.0, (0.5,)),))
    result = plan(trajectory, 100.0, 100.0, lambda _t: at(0.0), unlimited, False, 'test',
                  arrays=validate(trajectory, unlimited, 'test'))
    assert len(result.warnings) == 1 and 'joint j has no velocity limit' in result.warnings[0]
    assert 'limits.max_velocity' in result.warnings[0]
    assert not planned([TrajectoryPoint(1.0, (0.5,))]).warnings  # type: ignore[attr-defined]
    # the configuration leaves it out, the drive has one (0x607F = 0x6080 = 200,000 counts/s in
    # the demo's EDS): the drive's is checked, and nothing is left unlimited
    data = demo_data()
    del data['nodes']['base_drive']['axes'][0]['limits']['max_velocity']
    with running(config_from(data)) as (master, _sim):
        limits = master.axes['base_joint'].config.limits
        assert limits.sources['max_velocity'] == 'drive 0x607F'  # both 200,000: the first of the pair
        assert limits.max_velocity == pytest.approx(200_000 * 2 * math.pi / 65536 / 10)
        said = [e.message for e in master.events if 'joint base_joint: limits checked' in e.message]
        assert len(said) == 1 and 'velocity 1.91748 (drive 0x607F)' in said[0] and 'no velocity limit' not in said[0]


def test_on_violation_quick_stop_stops_the_axis_and_a_refused_pvt_point_is_never_pushed() -> None:
    data = demo_data()
    data['nodes']['base_drive']['axes'][0]['limits']['on_violation'] = 'quick_stop'
    with running(config_from(data)) as (master, sim):
        axis = master.axes['base_joint']
        axis.enable(timeout=2.0)
        here = axis.snapshot().position
        axis.set_setpoint_source(lambda _t: Setpoint(position=here + 0.5))  # a jump past every check
        eventually(lambda: axis.snapshot().state in (State.QUICK_STOP_ACTIVE, State.SWITCH_ON_DISABLED), 2.0,
                   'quick stop')
        snapshot = axis.snapshot()
        assert 'set-point refused' in snapshot.setpoint_refused and 'quick stop' in snapshot.setpoint_refused
        assert [e for e in master.events if e.kind is EventKind.SETPOINT_REFUSED and e.joint == 'base_joint']
        assert abs(sim.drive(2).axis(0).position - axis.config.scaling.position_to_device(here)) < 500
        axis.enable(timeout=2.0)
        assert not axis.snapshot().setpoint_refused


def test_a_pvt_point_beyond_the_limits_is_never_pushed() -> None:
    data = yaml.safe_load(AKD_EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('akdpvt')
    with running(config_from(data)) as (master, sim):
        axis = master.axes['joint1']
        axis.enable(timeout=2.0)
        assert axis.pvt is not None and axis.stream_strategy() == 'pvt'
        buffer = sim.drive(1).axis(0).ip
        scaling = axis.config.scaling
        here = axis.snapshot().position
        axis.push_interpolation_point(scaling.position_to_device(here + 0.01), 10, 0)  # within: pushed
        eventually(lambda: len(buffer) == 1, 2.0, 'the point in the drive buffer')
        axis.push_interpolation_point(scaling.position_to_device(10.0), 10, 0)  # beyond max_position 6.28
        snapshot = eventually(lambda: axis.snapshot() if axis.snapshot().halted else None, 2.0, 'held')
        assert 'PVT point: position set-point 10 is above limits.max_position 6.28' in snapshot.setpoint_refused
        time.sleep(0.1)
        assert len(buffer) == 1  # the refused point never reached the drive
