"""Modes of operation of a simulated CiA 402 axis: the catalogue that makes a mode object for a
mode code. Each mode drives the demand in Operation Enabled and sets the mode-specific statusword
bits 10, 12 and 13 (:mod:`~drive_bridge.sim.opmode` the base, :mod:`~drive_bridge.sim.profilemodes`
pp/pv/tq, :mod:`~drive_bridge.sim.homingmode` hm, :mod:`~drive_bridge.sim.cyclicmodes` ip/csp/csv/cst).

One class per mode, all with the same small interface, so the axis state machine
(:mod:`drive_bridge.sim.axis402`) never tests mode numbers. Halt, quick stop and
fault ramps are the axis' business; a mode only runs while the axis is enabled and
not stopping, and is told to ``resume`` after a halt.

Choices CiA 402 leaves open:

- CSx and IP interpolate over the interpolation time period 0x60C2 (as Elmo, AKD:
  a master must set it to its SYNC period); without 0x60C2 in the EDS over 0x1006,
  else over the measured SYNC period. A set-point is reached one period after the
  SYNC that latched it; a late SYNC holds the last set-point, an early one starts the
  next segment from wherever the demand is.
- IP: an empty buffer holds the last point (no error); a halt pauses consumption
  and, released, continues from the stopped position to the next point.
- PV bit 12 "speed = 0" uses the velocity window 0x606D as threshold (0x606F is not
  in the generic EDS).
- HM: halt or bit 4 falling interrupts homing; the attained bit stays until the next
  start; the home switch is a point, found from either side.
"""
from __future__ import annotations

from drive_bridge.cia402.modes import Mode
from drive_bridge.sim.cyclicmodes import CyclicSynchronous, InterpolatedPosition
from drive_bridge.sim.homingmode import Homing
from drive_bridge.sim.opmode import OpMode
from drive_bridge.sim.profilemodes import ProfilePosition, ProfileTorque, ProfileVelocity

__all__ = ['IMPLEMENTED_MODES', 'CyclicSynchronous', 'Homing', 'InterpolatedPosition', 'OpMode', 'ProfilePosition',
           'ProfileTorque', 'ProfileVelocity', 'make_mode']


def make_mode(code: int) -> OpMode:
    """A fresh mode object for a mode code (the code was validated against 0x6502)."""
    if code == Mode.PROFILE_POSITION:
        return ProfilePosition()
    if code == Mode.PROFILE_VELOCITY:
        return ProfileVelocity()
    if code == Mode.PROFILE_TORQUE:
        return ProfileTorque()
    if code == Mode.HOMING:
        return Homing()
    if code == Mode.INTERPOLATED_POSITION:
        return InterpolatedPosition()
    if code in (Mode.CYCLIC_SYNC_POSITION, Mode.CYCLIC_SYNC_VELOCITY, Mode.CYCLIC_SYNC_TORQUE):
        return CyclicSynchronous(code)
    mode = OpMode()
    mode.code = code
    return mode


IMPLEMENTED_MODES = frozenset({Mode.NO_MODE, Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE,
                               Mode.HOMING, Mode.INTERPOLATED_POSITION, Mode.CYCLIC_SYNC_POSITION,
                               Mode.CYCLIC_SYNC_VELOCITY, Mode.CYCLIC_SYNC_TORQUE})
