"""The bridge's own position loop for drives that take only velocity set-points (a CiA 402
drive in pv/csv without csp, the S120, a drive without CiA 402): every SYNC the velocity
set-point is the desired velocity plus gain times the position error (no more than the joint
can brake from within that error), clamped to the joint's velocity limit and rate-limited by
its acceleration limit; set ``max_acceleration`` at or below the drive's own ramp. The position error compares the
desired position at the time the measured position was sampled (the previous SYNC) with the
measurement, so the TPDO's delay is not taken for an error."""
from __future__ import annotations

import math
from dataclasses import dataclass

from drive_bridge.model import AxisLimits, PositionLoopConfig


@dataclass
class LoopOutput:
    velocity: float  # SI, the set-point to send
    error: float  # SI, desired minus measured position
    exceeded: bool  # |error| beyond the following-error limit


class PositionLoop:
    """State of one joint's loop; ``step`` once per cycle with SI values."""

    def __init__(self, config: PositionLoopConfig, limits: AxisLimits) -> None:
        self.config = config
        self.limits = limits
        self.last_velocity = 0.0

    def reset(self, velocity: float = 0.0) -> None:
        """Start again from ``velocity`` (the drive's actual velocity when a stream begins)."""
        self.last_velocity = velocity

    def step(self, desired_position: float, desired_velocity: float, measured: float, dt: float,
             resolution: float = 0.0) -> LoopOutput:
        """``resolution``: SI of one unit of the measured position; holding (no desired velocity),
        an error within it is no error (the set-point is then exactly 0, not a dither of
        +-gain x one unit)."""
        error = desired_position - measured
        holding = desired_velocity == 0.0 and abs(error) <= resolution
        correction = 0.0 if holding else self.config.gain * error
        accel = self.limits.max_acceleration
        if accel is not None:  # never ask for more than the joint can brake to rest within the error
            reach = math.sqrt(2.0 * accel * abs(error))
            correction = max(-reach, min(reach, correction))
        velocity = desired_velocity + correction
        limit = self.limits.max_velocity
        if limit is not None:
            velocity = max(-limit, min(limit, velocity))
        if accel is not None and dt > 0:
            change = accel * dt
            velocity = max(self.last_velocity - change, min(self.last_velocity + change, velocity))
        if not math.isfinite(velocity):
            velocity = 0.0
        self.last_velocity = velocity
        bound = self.config.following_error
        return LoopOutput(velocity, error, bound is not None and abs(error) > bound)
