"""The S120's bus units and an axis' SI scaling from them (shared/drives/sinamics-s120-cbc10.md §5).

What the drive object sends and takes, read from it at boot (:class:`DriveUnits`):

- position 0x6063 (r0482): encoder increments with fine resolution, p0408 x 2^p0418 per motor
  revolution;
- velocity 0x60FF / 0x606C: increments per second on the same scale with an encoder, rpm
  without one (see the axis option ``encoder``), each times the velocity factor 0x6094 (p8798, numerator / divisor,
  default 1/1): bus value = internal value x divisor / numerator;
- torque 0x6071 / 0x6077: per mille of the rated motor torque r0333.

The axis' own ``drive:`` settings (:mod:`drive_bridge.families.s120.options`) add the mechanics:
``gear_ratio`` (motor revolutions per joint revolution, or per ``metres_per_revolution`` of a
prismatic joint), ``direction`` and ``offset``. The joint's SI factors are then (revolute):

    position  rad / inc   = direction x 2 pi / (p0408 x 2^p0418) / gear_ratio
    velocity  rad/s / bus = position factor x numerator / divisor   (encoder)
                          = direction x 2 pi / 60 / gear_ratio x numerator / divisor   (rpm)
    effort    N·m / bus   = direction x r0333 / 1000 x gear_ratio
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drive_bridge.families.s120.options import AxisOptions
from drive_bridge.model import AxisScaling, JointType


@dataclass(frozen=True)
class DriveUnits:
    """One drive object's units as read at boot."""

    encoder_pulses: int  # p0408
    fine_resolution: int  # p0418, bits
    rated_torque: float  # r0333, N·m
    encoder: bool = True  # a commissioned encoder: velocity in increments/s (else rpm, no position)
    velocity_numerator: int = 1  # 0x6094:1 (p8798[0])
    velocity_divisor: int = 1  # 0x6094:2 (p8798[1])
    max_speed_rpm: float | None = None  # p1082
    ramp_down_s: float | None = None  # p1121

    @property
    def has_encoder(self) -> bool:
        return self.encoder and self.encoder_pulses > 0

    @property
    def increments_per_revolution(self) -> int:
        return self.encoder_pulses << self.fine_resolution if self.has_encoder else 0

    def describe(self) -> str:
        velocity = ('inc/s' if self.has_encoder else 'rpm (no encoder)')
        if (self.velocity_numerator, self.velocity_divisor) != (1, 1):
            velocity += f' x {self.velocity_divisor}/{self.velocity_numerator} (0x6094)'
        position = (f'{self.increments_per_revolution} inc/rev (p0408 {self.encoder_pulses}, p0418 '
                    f'{self.fine_resolution})' if self.has_encoder else 'none (no encoder)')
        return f'position {position}, velocity {velocity}, torque per mille of r0333 = {self.rated_torque:g} N·m'

    def scaling(self, options: AxisOptions, joint_type: JointType) -> AxisScaling:
        """The joint's SI scaling (module docstring)."""
        per_revolution = (2 * math.pi if joint_type == 'revolute'
                          else options.metres_per_revolution or 1.0)  # SI per joint-side revolution
        sign = options.direction
        gear = options.gear_ratio
        velocity_factor = self.velocity_numerator / self.velocity_divisor
        if self.has_encoder:
            position = sign * per_revolution / self.increments_per_revolution / gear
            velocity = position * velocity_factor
        else:
            position = sign * per_revolution / gear  # 0x6063 has no meaning without an encoder
            velocity = sign * per_revolution / 60.0 / gear * velocity_factor
        effort_arm = gear if joint_type == 'revolute' else gear * 2 * math.pi / per_revolution
        effort = sign * self.rated_torque / 1000.0 * effort_arm
        return AxisScaling(position_factor=position, position_offset=options.offset, velocity_factor=velocity,
                           effort_factor=effort)

    def stop_deceleration(self, options: AxisOptions, joint_type: JointType) -> float | None:
        """The drive's own ramp-down (p1082 / p1121) at the joint, SI/s^2; None when unknown."""
        if not self.max_speed_rpm or not self.ramp_down_s:
            return None
        per_revolution = 2 * math.pi if joint_type == 'revolute' else options.metres_per_revolution or 1.0
        return self.max_speed_rpm / 60.0 * per_revolution / options.gear_ratio / self.ramp_down_s
