"""Drive units <-> SI for one OPEN drive axis (shared/drives/opendrive.md §5, §3.9).

=================  ======================================  ===================================
quantity           raw (INT16)                             SI at the motor
=================  ======================================  ===================================
speed 0x201A       v, 16384 = n_MAX                        ω = v / 16384 · n_MAX · 2π / 60
speed 0x201D       θ, electrical angle per PWM period      ω = θ · f_pwm · 2π / (65536 · pp)
torque 0x201C      t, 4095 = T_nom                         τ = t / 4095 · T_nom
velocity actual    v, F = n_MAX (F from its 0x2003 /       ω = v / F · n_MAX · 2π / 60
                   0x2004 representation word)
torque actual      t, F = T_nom (the same)                 τ = t / F · T_nom
position element   counts (wraps at 16 bits)               φ = counts · 2π / counts_per_rev
=================  ======================================  ===================================

F is the raw value of 100 % (:mod:`~drive_bridge.families.opendrive.representation`, read at
boot): 16384 and 4095, as the references, until the boot read the words.

The joint sees the motor through ``gear_ratio`` and ``direction``: joint angle = direction ·
motor angle / gear ratio, joint torque = direction · motor torque · gear ratio. A reference
beyond what INT16 carries (about ±2 n_MAX, ±8 T_nom) is refused by :meth:`Units.speed_raw`
/ :meth:`Units.torque_raw` (``None``), never wrapped; streamed set-points saturate instead.
"""
from __future__ import annotations

import math

from drive_bridge.families.opendrive import objects as od
from drive_bridge.families.opendrive.options import DriveOptions
from drive_bridge.families.opendrive.representation import Scaling

SPEED_FULL_SCALE = 16384  # 0x201A and the velocity quantity: n_MAX
TORQUE_FULL_SCALE = 4095  # 0x201C, 0x201B and the torque quantity: T_nom
TURN = 65536  # 0x201D: increments per electrical revolution
RPM = 2 * math.pi / 60


class Units:
    """Conversions of one axis (thread-safe: no state)."""

    def __init__(self, options: DriveOptions, scaling: Scaling | None = None) -> None:
        self.options = options
        self.scaling = scaling = scaling if scaling is not None else Scaling()
        self.n_max = options.n_max_rpm * RPM  # rad/s at the motor
        # SI at the joint per raw unit
        self.joint_per_motor = options.direction / options.gear_ratio
        speed_per_unit = self.n_max / SPEED_FULL_SCALE * self.joint_per_motor  # 0x201A
        self.velocity_per_unit = self.n_max / scaling.velocity_full_scale * self.joint_per_motor  # velocity actual
        self.increment_per_unit = (options.pwm_frequency * 2 * math.pi / (TURN * options.pole_pairs)
                                   * self.joint_per_motor)  # 0x201D
        gear_torque = options.rated_torque * options.direction * options.gear_ratio
        self.torque_per_unit = gear_torque / TORQUE_FULL_SCALE  # 0x201C
        self.torque_actual_per_unit = gear_torque / scaling.torque_full_scale  # torque actual
        self.reference_per_unit = (speed_per_unit if options.speed_reference == od.SPEED_REFERENCE
                                   else self.increment_per_unit)
        counts = options.position.counts_per_revolution if options.position is not None else 1.0
        self.position_per_count = 2 * math.pi / counts * self.joint_per_motor

    # -- feedback -------------------------------------------------------------------------
    def velocity_si(self, raw: float) -> float:
        return raw * self.velocity_per_unit

    def torque_si(self, raw: float) -> float:
        return raw * self.torque_actual_per_unit

    def position_si(self, counts: float) -> float:
        return counts * self.position_per_count

    # -- references ---------------------------------------------------------------------------
    def speed_raw(self, velocity: float) -> int | None:
        """The speed reference for a joint velocity (rad/s or m/s), None beyond INT16."""
        raw = round(velocity / self.reference_per_unit)
        return raw if od.INT16_MIN <= raw <= od.INT16_MAX else None

    def torque_raw(self, effort: float) -> int | None:
        """The torque reference for a joint effort (N·m), None beyond INT16."""
        raw = round(effort / self.torque_per_unit)
        return raw if od.INT16_MIN <= raw <= od.INT16_MAX else None

    @staticmethod
    def saturate(raw: float) -> int:
        return int(max(od.INT16_MIN, min(od.INT16_MAX, round(raw))))

    def speed_raw_saturated(self, velocity: float) -> int:
        return self.saturate(velocity / self.reference_per_unit)

    def torque_raw_saturated(self, effort: float) -> int:
        return self.saturate(effort / self.torque_per_unit)

    def velocity_range(self) -> tuple[float, float]:
        """The joint velocities the speed reference carries (low, high)."""
        ends = sorted((od.INT16_MIN * self.reference_per_unit, od.INT16_MAX * self.reference_per_unit))
        return ends[0], ends[1]

    def effort_range(self) -> tuple[float, float]:
        ends = sorted((od.INT16_MIN * self.torque_per_unit, od.INT16_MAX * self.torque_per_unit))
        return ends[0], ends[1]
