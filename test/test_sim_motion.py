"""The simulator's motion model as pure functions (no bus)."""
from __future__ import annotations

import math

import pytest

from drive_bridge.sim.motion import (
    Segment,
    lag_follow,
    max_acceleration,
    motor_torque,
    position_step,
    ramp_value,
    ramp_velocity,
    stop_step,
    torque_drive,
    velocity_step,
    wrap_int32,
)


def run_position(target: float, v_max: float, acc: float, dec: float, dt: float = 0.004,
                 p: float = 0.0, v: float = 0.0, limit: float = 10.0) -> tuple[list[float], list[float], float]:
    ps, vs, t = [], [], 0.0
    arrived = False
    while not arrived and t < limit:
        p, v, arrived = position_step(p, v, target, v_max, acc, dec, dt)
        ps.append(p)
        vs.append(v)
        t += dt
    return ps, vs, t


def test_ramp_velocity_uses_acceleration_up_and_deceleration_down() -> None:
    assert ramp_velocity(0.0, 100.0, 1000.0, 10.0, 0.01) == pytest.approx(10.0)
    assert ramp_velocity(100.0, 0.0, 1000.0, 10.0, 0.01) == pytest.approx(99.9)
    assert ramp_velocity(-100.0, -200.0, 1000.0, 10.0, 0.01) == pytest.approx(-110.0)
    assert ramp_velocity(50.0, -50.0, 1000.0, 10.0, 0.01) == pytest.approx(49.9)  # reversing: brake first
    assert ramp_velocity(5.0, 5.0, 1.0, 1.0, 1.0) == 5.0
    assert ramp_velocity(0.0, 1.0, 1000.0, 1000.0, 1.0) == 1.0  # never past the target


def test_trapezoid_reaches_target_exactly_within_limits_and_in_time() -> None:
    ps, vs, t = run_position(10000.0, 50000.0, 500000.0, 250000.0)
    assert ps[-1] == 10000.0 and vs[-1] == 0.0
    assert max(vs) <= 50000.0 + 1e-6
    assert all(b >= a - 1e-9 for a, b in zip(ps, ps[1:])), 'no overshoot, monotonic'
    # 10000 counts: accelerate 0.1 s (2500), cruise, brake 0.2 s (5000): 0.3 s + 2500/50000 = 0.35 s
    assert t == pytest.approx(0.35, abs=0.02)
    accels = [(b - a) / 0.004 for a, b in zip(vs, vs[1:])]
    assert max(accels) <= 500000.0 * 1.01 and min(accels) >= -250000.0 * 1.01


def test_short_move_is_triangular_and_negative_moves_work() -> None:
    ps, vs, t = run_position(-100.0, 1e6, 1e5, 1e5)
    assert ps[-1] == -100.0
    assert min(vs) > -math.sqrt(1e5 * 100) * 1.1  # never reaches v_max: triangle
    assert t == pytest.approx(2 * math.sqrt(100 / 1e5), abs=0.01)


def test_target_behind_a_fast_axis_is_overshot_and_approached_again() -> None:
    ps, vs, _t = run_position(0.0, 50000.0, 500000.0, 500000.0, p=-100.0, v=40000.0)
    assert max(ps) > 1000.0  # cannot stop within 100 counts at 40000 counts/s
    assert ps[-1] == 0.0 and vs[-1] == 0.0


def test_velocity_and_stop_steps_integrate_the_trapezoid() -> None:
    p, v = 0.0, 0.0
    for _ in range(100):
        p, v = velocity_step(p, v, 1000.0, 10000.0, 10000.0, 0.001)
    assert v == pytest.approx(1000.0)
    assert p == pytest.approx(0.5 * 10000.0 * 0.1 ** 2, rel=1e-6)
    q, w = stop_step(0.0, 1000.0, 10000.0, 0.2)
    assert w == 0.0 and q == pytest.approx(50.0, rel=0.5)


def test_lag_follows_a_ramp_with_error_velocity_times_tau() -> None:
    tau, v_cmd, dt = 0.002, 10000.0, 0.004
    p, v, d = 0.0, 0.0, 0.0
    for _ in range(200):
        p, v = lag_follow(p, v, d, d + v_cmd * dt, dt, tau, 1e9, 1e12)
        d += v_cmd * dt
    assert d - p == pytest.approx(v_cmd * tau, rel=1e-3)
    assert v == pytest.approx(v_cmd, rel=1e-3)
    p2, _ = lag_follow(0.0, 0.0, 100.0, 100.0, 1.0, 0.0, 1e9, 1e12)
    assert p2 == 100.0  # no lag: exact


def test_lag_is_limited_by_speed_and_acceleration() -> None:
    p, v = 0.0, 0.0
    p, v = lag_follow(p, v, 1e6, 1e6, 0.004, 0.002, 200000.0, 1e7)
    assert v == pytest.approx(1e7 * 0.004)  # acceleration limit
    for _ in range(100):
        p, v = lag_follow(p, v, 1e6, 1e6, 0.004, 0.002, 200000.0, 1e7)
    assert v == pytest.approx(200000.0)  # speed limit
    assert p < 1e6


def test_torque_drive_reaches_the_friction_balance_and_coasts_down() -> None:
    p, v = 0.0, 0.0
    for _ in range(5000):
        p, v = torque_drive(p, v, 100.0, 0.001, 2e-4, 1e-3, 1e9)
    assert v == pytest.approx(100.0 / 1e-3, rel=1e-3)  # friction balance
    for _ in range(5000):
        p, v = torque_drive(p, v, 0.0, 0.001, 2e-4, 1e-3, 1e9)
    assert abs(v) < 1.0
    _p, capped = torque_drive(0.0, 0.0, 1e6, 1.0, 2e-4, 0.0, 5000.0)
    assert capped == 5000.0


def test_torque_helpers_and_wrap() -> None:
    assert motor_torque(1000.0, 100.0, 0.1, 0.5) == pytest.approx(150.0)
    assert max_acceleration(3000.0, 0.0, 2e-4, 1e-3) == pytest.approx(1.5e7)
    assert max_acceleration(3000.0, 0.0, 0.0, 1e-3) == math.inf
    assert ramp_value(0.0, 100.0, 1000.0, 0.01) == pytest.approx(10.0)
    assert ramp_value(0.0, -5.0, 1000.0, 0.01) == -5.0
    assert wrap_int32(2 ** 31) == -(2 ** 31)
    assert wrap_int32(-1.4) == -1


def test_segment_interpolates_and_holds_the_end() -> None:
    seg = Segment(0.0, 100.0, 0.004)
    assert seg.advance(0.001) == pytest.approx(25.0)
    assert seg.slope == pytest.approx(25000.0)
    assert seg.advance(0.01) == 100.0 and seg.done and seg.slope == 0.0
