"""The SERVOSTAR's bus units and an axis' SI scaling from them (shared/drives/servostar-400-600.md §7).

- position 0x2070:03 (actual): increments, 2^20 per motor revolution (the EDS's reading; the OD
  table's "depends on PRBASE" is not followed); 0x2022:04 (trajectory setpoint): 2^PRBASE per motor
  revolution (PRBASE 0x35D1: 16 or 20 bits, read at boot), converted by the driver;
- speed 0x2070:02: 1875/262144 rpm per bit (2^-25 revolutions per 250 us);
- VLIM 0x3622 (rpm) bounds the step between two trajectory setpoints: below VLIM x PTBASE;
- torque 0x6077: per mille of the rated torque;
- profile position 0x607A: user units, 0x6093:2 user units per 0x6093:1 increments;
- profile velocity 0x60FF: increments (2^20 per revolution: the speed controller's own
  resolution) per 250 us sample (0x6094 = 0/0, the power-on value).

The axis' ``drive:`` settings (:mod:`~drive_bridge.families.servostar.options`) add the mechanics:

    position  rad / inc        = direction x 2 pi / 2^20 / gear_ratio
    velocity  rad/s / bit      = direction x 2 pi / 60 x 1875/262144 / gear_ratio
    effort    N·m / per mille  = direction x rated_torque / 1000 x gear_ratio
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from drive_bridge.families.servostar import objects as o
from drive_bridge.families.servostar.options import AxisOptions
from drive_bridge.model import AxisScaling, JointType

ACTUAL_COUNTS_PER_REV = 1 << 20
PV_COUNTS_PER_REV = 1 << 20
PV_SAMPLE = 250e-6  # s


@dataclass(frozen=True)
class DriveUnits:
    """What the boot read from one drive."""

    prbase: int = 20  # bits per motor revolution
    vlim_rpm: float | None = None  # speed limit VLIM
    pemax: int | None = None  # max following error (0x2020:03, user units = increments by default)
    dec_ms: int | None = None  # deceleration ramp DEC (ms from VLIM to 0)
    pp_numerator: int = 1 << 20  # 0x6093:1 increments
    pp_feed: int = 10000  # 0x6093:2 user units

    @property
    def increments_per_revolution(self) -> int:
        """Of the actual position 0x2070:03 (and of the axis' device units)."""
        return ACTUAL_COUNTS_PER_REV

    def to_setpoint(self, increments: int) -> int:
        """Device units (2^20 per revolution) -> 0x2022:04 (2^PRBASE per revolution)."""
        shift = 20 - self.prbase
        return increments if shift <= 0 else round(increments / (1 << shift))

    def from_setpoint(self, value: int) -> int:
        shift = 20 - self.prbase
        return value if shift <= 0 else value << shift

    def describe(self) -> str:
        vlim = f'{self.vlim_rpm:g} rpm' if self.vlim_rpm is not None else 'unknown'
        pemax = f'{self.pemax}' if self.pemax is not None else 'unknown'
        return (f'PRBASE {self.prbase} ({1 << self.prbase} setpoint increments/rev), VLIM {vlim}, '
                f'PEMAX {pemax}')

    @staticmethod
    def per_revolution(options: AxisOptions, joint_type: JointType) -> float:
        """SI per joint-side revolution."""
        return 2 * math.pi if joint_type == 'revolute' else options.metres_per_revolution or 1.0

    def scaling(self, options: AxisOptions, joint_type: JointType) -> AxisScaling:
        per_revolution = self.per_revolution(options, joint_type)
        sign, gear = options.direction, options.gear_ratio
        position = sign * per_revolution / self.increments_per_revolution / gear
        velocity = sign * per_revolution / 60.0 * o.SPEED_RPM_PER_BIT / gear
        effort_arm = gear if joint_type == 'revolute' else gear * 2 * math.pi / per_revolution
        effort = sign * (options.rated_torque or 1.0) / 1000.0 * effort_arm
        return AxisScaling(position_factor=position, position_offset=options.offset, velocity_factor=velocity,
                           effort_factor=effort)

    def joint_speed_limit(self, options: AxisOptions, joint_type: JointType) -> float | None:
        """VLIM at the joint (SI/s), None when unknown."""
        if self.vlim_rpm is None or self.vlim_rpm <= 0:
            return None
        return self.vlim_rpm / 60.0 * self.per_revolution(options, joint_type) / options.gear_ratio

    def step_limit(self, period: float) -> float | None:
        """The largest step (increments) between two setpoints one ``period`` apart: VLIM x period."""
        if self.vlim_rpm is None or self.vlim_rpm <= 0:
            return None
        return self.vlim_rpm / 60.0 * period * self.increments_per_revolution

    def to_user_units(self, increments: int) -> int:
        """Increments -> the user units of 0x607A (0x6093)."""
        return round(increments * self.pp_feed / self.pp_numerator) if self.pp_numerator else increments

    def pv_target(self, si_velocity: float, options: AxisOptions, joint_type: JointType) -> int:
        """A joint velocity (SI/s) as 0x60FF: 2^20 increments per revolution per 250 us."""
        motor_rev_per_s = si_velocity / self.per_revolution(options, joint_type) * options.gear_ratio \
            * options.direction
        return round(motor_rev_per_s * PV_COUNTS_PER_REV * PV_SAMPLE)
