"""The quirks of an S120 drive object: what its CiA 402 axis does differently (handed to the axis
as :class:`S120Quirks`).

- Units come from the drive: the boot reads p0408 / p0418 / r0333 / 0x6094 (and p1082 / p1121)
  of the axis' drive object and :meth:`S120Quirks.apply_units` sets the axis' SI scaling from them
  and its ``drive:`` settings; until then the axis is unavailable anyway (its node is booting).
- Velocity mode (vl) takes its set-point from 0x6042 (rpm, INTEGER16), not 0x60FF: every velocity
  target the axis decides is also written there, converted, while the axis is in vl (else 0).
- No target position: the S120 has no 0x607A (no position mode through CANopen), so the axis'
  "follow the actual position" write of the position target is never sent. Position control is
  the bridge's loop over 0x60FF (the family's ``modes.default_position_loop``).
- Fault acknowledge: 0x1003:00 = 0 (§6.3; it acknowledges the faults of every drive object of the
  Control Unit) as well as the controlword bit 7 edge of this axis.
- Stop deceleration without a ``max_acceleration`` limit: the drive's ramp-down p1082 / p1121.
- A trajectory with positions needs an encoder (0x6063 means nothing without one).
"""
from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace

from drive_bridge.cia402 import objects as cia
from drive_bridge.cia402.errors import AxisError
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.quirks import AxisPort, AxisQuirks, Output
from drive_bridge.families.s120 import objects as s
from drive_bridge.families.s120.options import AxisOptions
from drive_bridge.families.s120.units import DriveUnits
from drive_bridge.model import AxisConfig

log = logging.getLogger('drive_bridge.families.s120')
NO_TARGET = frozenset({'target_position'})  # outputs the S120 does not have


class S120Quirks(AxisQuirks):
    """One drive object (axis slot) of an S120 node."""

    def __init__(self, config: AxisConfig) -> None:
        self.options = AxisOptions.of(config.drive)
        self.units: DriveUnits | None = None
        self.drive_object: int | None = None  # p8743[slot], read at boot
        self.vl = False  # the drive object has 0x6042

    def attach(self, axis: AxisPort) -> None:
        super().attach(axis)
        vl_target = (cia.for_axis(s.VL_TARGET_VELOCITY, axis.config.slot), 0)
        self.vl = axis.node.has_object(*vl_target)
        axis.key['vl_target'] = vl_target

    def apply_units(self, units: DriveUnits, drive_object: int | None = None) -> None:
        """The drive object's units as read at boot: the axis' SI scaling follows them."""
        self.units = units
        self.drive_object = drive_object
        config = self.axis.config
        self.axis.update_config(replace(config, scaling=units.scaling(self.options, config.joint_type)))

    # -- CiA 402 axis details ------------------------------------------------------------------------
    def outputs(self, name: str, value: int | float) -> Sequence[Output]:
        if name in NO_TARGET:
            return ()
        if name == 'target_velocity' and self.vl:
            return (('vl_target', self._vl_rpm(value) if self.axis.mode == Mode.VELOCITY else 0), (name, value))
        return ((name, value),)

    def _vl_rpm(self, value: int | float) -> int:
        """A 0x60FF value as the motor speed in rpm for 0x6042 (INTEGER16)."""
        config = self.axis.config
        joint = config.scaling.velocity_to_si(value)
        per_revolution = (2 * math.pi if config.joint_type == 'revolute'
                          else self.options.metres_per_revolution or 1.0)
        rpm = joint / per_revolution * 60.0 * self.options.gear_ratio * self.options.direction
        return max(-0x8000, min(0x7FFF, round(rpm)))

    def reset_fault(self, timeout: float | None) -> None:
        """0x1003:00 = 0 (the CU's acknowledge of every DO's faults), then the bit 7 edge."""
        try:
            self.axis.node.sdo_write(s.ERROR_FIELD, 0, 0)
        except Exception as exc:  # the edge may still acknowledge it: say why the first way failed
            log.warning('%s: fault acknowledge 0x1003:00 = 0 failed: %s; trying the controlword edge',
                        self.axis.where(), exc)
        super().reset_fault(timeout)

    def stop_deceleration(self) -> float | None:
        if self.axis.config.limits.max_acceleration is None and self.units:
            return self.units.stop_deceleration(self.options, self.axis.config.joint_type) or None
        return None

    def check_trajectory(self, has_positions: bool, has_velocities: bool) -> None:
        if has_positions and self.units is not None and not self.units.has_encoder:
            raise AxisError(f'{self.axis.where()}: the drive object has no encoder (p0408 = 0), so 0x6063 measures '
                            'nothing and a trajectory with positions cannot be followed')
