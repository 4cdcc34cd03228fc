"""A simple motor behind the OPEN drive (the appendix has no model; this is the simulator's).

Speed mode: while the drive runs, the speed follows the reference with a first-order lag
(time constant ``speed_time_constant``), its acceleration limited by the torque limit
(torque = inertia x acceleration + viscous friction x speed). Torque mode: the torque is the
reference clipped by the limit, the speed integrates (torque - friction x speed) / inertia,
held within +-n_MAX. Drive not running (RUN low, an alarm, life guarding 'stop'): the
inverter is off, torque 0, the motor coasts down with the time constant
``coast_time_constant``. The mechanical angle integrates the speed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class Motor:
    inertia: float  # kg m^2
    friction: float  # N m s / rad, viscous
    speed_time_constant: float  # s
    coast_time_constant: float  # s
    n_max: float  # rad/s, speed mode clamp in torque mode
    speed: float = 0.0  # rad/s, mechanical
    torque: float = 0.0  # N m
    angle: float = 0.0  # rad, mechanical, not wrapped

    def reset(self) -> None:
        self.speed = self.torque = self.angle = 0.0

    def step(self, dt: float, running: bool, torque_mode: bool, speed_ref: float, torque_ref: float,
             torque_limit: float) -> None:
        """Advance ``dt`` s; references in rad/s and N m, ``torque_limit`` >= 0 in N m."""
        if dt <= 0:
            return
        w = self.speed
        if not running:
            self.torque = 0.0
            w_new = w * math.exp(-dt / self.coast_time_constant) if self.coast_time_constant > 0 else 0.0
        elif torque_mode:
            self.torque = max(-torque_limit, min(torque_limit, torque_ref))
            w_new = w + (self.torque - self.friction * w) / self.inertia * dt
            w_new = max(-self.n_max, min(self.n_max, w_new))
        else:
            tau = self.speed_time_constant
            w_new = speed_ref + (w - speed_ref) * math.exp(-dt / tau) if tau > 0 else speed_ref
            torque = self.inertia * (w_new - w) / dt + self.friction * w_new
            if abs(torque) > torque_limit:
                torque = math.copysign(torque_limit, torque)
                w_new = w + (torque - self.friction * w) / self.inertia * dt
            self.torque = torque
        self.angle += 0.5 * (w + w_new) * dt
        self.speed = w_new
