"""The motion model of one simulated axis, as pure functions (unit-tested alone).

Two stages, as in a real servo:

1. the *demand* (0x6062/0x606B): what the drive's trajectory generator or the
   master's set-points ask for. Profile generators here limit it by velocity and
   acceleration (trapezoid); cyclic modes interpolate set-points linearly.
2. the *plant* (0x6064/0x606C/0x6077): the motor follows the demand through a
   first-order lag (time constant ``tau``), physically limited by the maximum motor
   speed and by the torque limit (acceleration <= (torque limit - friction) / inertia).
   Hence a real following error (0x60F4) that grows with speed and explodes when a
   set-point jumps.

Units: position counts, velocity counts/s, acceleration counts/s^2, torque per mille
of rated torque, time s. Internally floats; the axis rounds when it reports.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

SUBSTEP = 0.001  # s: profile generators integrate in steps no longer than this


def clamp(value: float, low: float, high: float) -> float:
    return low if value < low else high if value > high else value


def wrap_int32(value: float) -> int:
    """Round to counts and wrap like a 32-bit position register."""
    return (int(round(value)) + 2 ** 31) % 2 ** 32 - 2 ** 31


def _rate(v: float, v_target: float, acc: float, dec: float) -> float:
    """``acc`` when speeding up in the same direction, else ``dec`` (braking, reversing)."""
    if v_target * v >= 0 and abs(v_target) > abs(v):
        return acc
    return dec


def ramp_velocity(v: float, v_target: float, acc: float, dec: float, dt: float) -> float:
    """Move ``v`` toward ``v_target``: by at most ``acc*dt`` when speeding up, ``dec*dt`` when slowing down."""
    if v == v_target:
        return v
    step = _rate(v, v_target, acc, dec) * dt
    if v_target > v:
        return min(v_target, v + step)
    return max(v_target, v - step)


def ramp_value(x: float, target: float, slope: float, dt: float) -> float:
    """Linear slope limiter (torque slope 0x6087)."""
    step = slope * dt
    return min(target, x + step) if target > x else max(target, x - step)


def velocity_step(p: float, v: float, v_target: float, acc: float, dec: float,
                  dt: float) -> tuple[float, float]:
    """Profile velocity: ramp the velocity, integrate the position exactly (piecewise linear v)."""
    if v == v_target:
        return p + v * dt, v
    rate = _rate(v, v_target, acc, dec)
    reach = abs(v_target - v) / rate if rate > 0 else math.inf
    if reach < dt:  # target velocity reached inside the step, constant afterwards
        return p + 0.5 * (v + v_target) * reach + v_target * (dt - reach), v_target
    v_new = ramp_velocity(v, v_target, acc, dec, dt)
    return p + 0.5 * (v + v_new) * dt, v_new


def stop_step(p: float, v: float, dec: float, dt: float) -> tuple[float, float]:
    """Decelerate to standstill with ``dec`` (halt, quick stop, fault reaction ramps)."""
    return velocity_step(p, v, 0.0, dec, dec, dt)


def position_step(p: float, v: float, target: float, v_max: float, acc: float, dec: float,
                  dt: float) -> tuple[float, float, bool]:
    """Trapezoidal profile toward ``target`` from any start velocity; (p, v, arrived).

    Each sub-step takes the highest velocity from which the rest of the way can still
    be braked with ``dec`` (discrete look-ahead, so no overshoot on a normal move); a
    target behind a fast axis is overshot and approached again, as a real profile
    generator does with "change set immediately".
    """
    acc, dec, v_max = max(acc, 1e-9), max(dec, 1e-9), max(v_max, 0.0)
    steps = max(1, math.ceil(dt / SUBSTEP - 1e-9))
    h = dt / steps
    for _ in range(steps):
        distance = target - p
        if abs(distance) < 1e-6 and abs(v) <= dec * h:
            return target, 0.0, True
        direction = 1.0 if distance > 0 else -1.0
        along = v * direction
        radicand = (dec * h) ** 2 + 8.0 * dec * (abs(distance) - 0.5 * along * h)
        v_allowed = max(0.0, 0.5 * (math.sqrt(max(radicand, 0.0)) - dec * h))
        along_new = ramp_velocity(along, min(v_max, v_allowed), acc, dec, h)
        p_new = p + direction * 0.5 * (along + along_new) * h
        remaining = (target - p_new) * direction
        if (remaining <= 1e-6 and along_new <= 1.5 * dec * h) or (along_new == 0.0 and abs(remaining) < 1e-3):
            return target, 0.0, True
        p, v = p_new, along_new * direction
    return p, v, False


def lag_follow(p: float, v: float, d0: float, d1: float, dt: float, tau: float, v_max: float,
               a_max: float) -> tuple[float, float]:
    """The plant over one step: exact first-order lag to a demand moving linearly from
    ``d0`` to ``d1``, then limited to ``|v| <= v_max`` and ``|dv/dt| <= a_max``.

    ``v`` is the mean velocity of the previous step; returns the new (p, v).
    """
    if dt <= 0:
        return p, v
    if tau > 0:
        slope = (d1 - d0) / dt
        decay = math.exp(-dt / tau)
        p_new = d1 - slope * tau + (p - d0 + slope * tau) * decay
    else:
        p_new = d1
    v_new = (p_new - p) / dt
    v_lim = clamp(clamp(v_new, v - a_max * dt, v + a_max * dt), -v_max, v_max)
    if v_lim != v_new:
        return p + v_lim * dt, v_lim
    return p_new, v_new


def torque_drive(p: float, v: float, torque: float, dt: float, inertia: float, friction: float,
                 v_max: float) -> tuple[float, float]:
    """The plant driven by a torque: inertia*dv/dt = torque - friction*v (semi-implicit,
    stable for any dt); speed limited to ``v_max``. ``torque`` 0 is coasting."""
    if dt <= 0:
        return p, v
    if inertia <= 0:  # massless: velocity is where torque and friction balance
        v_new = torque / friction if friction > 0 else v
    else:
        v_new = (v + torque / inertia * dt) / (1.0 + friction / inertia * dt)
    v_new = clamp(v_new, -v_max, v_max)
    return p + 0.5 * (v + v_new) * dt, v_new


def motor_torque(acceleration: float, velocity: float, inertia: float, friction: float) -> float:
    """Torque (per mille) the motor needs for this motion."""
    return inertia * acceleration + friction * velocity


def max_acceleration(torque_limit: float, velocity: float, inertia: float, friction: float) -> float:
    """Largest acceleration the torque limit allows at ``velocity`` (inf without inertia)."""
    if inertia <= 0:
        return math.inf
    return max(0.0, torque_limit - friction * abs(velocity)) / inertia


@dataclass
class Segment:
    """Linear interpolation from ``start`` to ``end`` over ``duration`` s (cyclic modes, IP)."""

    start: float
    end: float
    duration: float
    elapsed: float = 0.0

    @property
    def value(self) -> float:
        if self.duration <= 0 or self.elapsed >= self.duration:
            return self.end
        return self.start + (self.end - self.start) * self.elapsed / self.duration

    @property
    def slope(self) -> float:
        """Rate of change while the segment runs (0 once it has ended)."""
        if self.duration <= 0 or self.elapsed >= self.duration:
            return 0.0
        return (self.end - self.start) / self.duration

    @property
    def done(self) -> bool:
        return self.elapsed >= self.duration

    def advance(self, dt: float) -> float:
        self.elapsed = min(self.duration, self.elapsed + dt)
        return self.value
