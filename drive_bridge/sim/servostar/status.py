"""The simulated SERVOSTAR's status and actual values as the master reads them [4.4, 6.1.6]: the
statusword's own bits over the CiA 402 ones, the status register 0x1002 (DRVSTAT), and the
actual values (0x2030, 0x6064, 0x606C, the ACTUAL list 0x2070 with the extended status
0x2070:11 of TPDO 33)."""
from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.statemachine import SW_VOLTAGE_ENABLED, SW_WARNING
from drive_bridge.sim.motion import wrap_int32
from drive_bridge.sim.servostar.modes import SPEED_ZERO
from drive_bridge.sim.servostar.objects import (
    ACTUAL,
    COUNTS_PER_REV,
    DRVCNFG,
    DRVCNFG_STATUS_BIT11,
    INTERNAL_LIMIT_WARNINGS,
    POSITION_CONTROLLER,
    POSITION_INCREMENTS,
    RATED_CURRENT_MA,
    SAMPLE,
    ST_ERROR,
    ST_HOME_POSITION,
    ST_IN_POSITION,
    ST_INIT_DONE,
    ST_REFERENCE_SET,
    ST_STAGE_ENABLED,
    ST_STANDSTILL,
    ST_TASK_ACTIVE,
    SW_FAULT,
    SW_INTERNAL_LIMIT,
    SW_REMOTE,
    SW_TOGGLE,
    SW_VOLTAGE_DISABLE,
    VALUE,
)
from drive_bridge.sim.servostar.units import Units
from drive_bridge.sim.store import key


class StatusAxis(Protocol):
    """The axis as its status registers read it."""

    toggle: bool
    homed: bool
    task_active: bool
    warnings: int
    p: float
    v: float
    dp: float
    dv: float
    torque: float
    units: Units

    @property
    def stage_enabled(self) -> bool: ...

    @property
    def star(self) -> Any: ...

    def standstill(self) -> bool: ...

    def extended_status(self) -> int: ...


def statusword(axis: StatusAxis, base: int, values: Mapping[int, Any]) -> int:
    """0x6041 from the CiA 402 axis' ``base``: no voltage-enabled, remote or limit bit of its
    own; bit 4 set while the DC link is off, the warning and toggle bits, bit 11 from the
    warnings with DRVCNFG's bit, bit 3 with the option fault_bit3."""
    sw = base & ~(SW_VOLTAGE_ENABLED | SW_REMOTE | SW_WARNING | SW_INTERNAL_LIMIT | SW_TOGGLE)
    star = axis.star
    if not star.dc_link:
        sw |= SW_VOLTAGE_DISABLE
    if axis.warnings:
        sw |= SW_WARNING
    if axis.toggle:
        sw |= SW_TOGGLE
    if values.get(key(DRVCNFG, VALUE), 0) & DRVCNFG_STATUS_BIT11 and axis.warnings & INTERNAL_LIMIT_WARNINGS:
        sw |= SW_INTERNAL_LIMIT
    if star.options['fault_bit3'] and star.error_pending():
        sw |= SW_FAULT
    return sw


def in_position(axis: StatusAxis, values: Mapping[int, Any]) -> bool:
    """0x1002 bit 19: at standstill within PEINPOS of the demand, and no motion task running
    (a task that starts leaves "in position" at once: 03h, not 0Bh, in §6.1.6's frames)."""
    if axis.task_active:
        return False
    window = axis.units.user_to_counts(values.get(key(POSITION_CONTROLLER, 2), 0x4000))
    return axis.standstill() and abs(axis.dp - axis.p) <= window


def status_register(axis: StatusAxis, values: Mapping[int, Any]) -> int:
    """0x1002 (DRVSTAT), the bits the simulation knows. Bits 18 (at the home position) and 19
    (in position) are 0 while a motion task runs (the frames of §6.1.6)."""
    units = axis.units
    bits = axis.warnings | ST_INIT_DONE
    if axis.task_active:
        bits |= ST_TASK_ACTIVE
    if axis.homed:
        bits |= ST_REFERENCE_SET
    if axis.homed and not axis.task_active:  # 03h, not 07h, at §6.1.6's set-point acknowledge
        offset = units.user_to_counts(values.get(key(0x2024, 6), 0))
        if abs(axis.p - offset) <= units.user_to_counts(values.get(key(POSITION_CONTROLLER, 2), 0x4000)):
            bits |= ST_HOME_POSITION
    if in_position(axis, values):
        bits |= ST_IN_POSITION
    if abs(axis.v) < SPEED_ZERO:
        bits |= ST_STANDSTILL
    if axis.stage_enabled:
        bits |= ST_STAGE_ENABLED
    if axis.star.error_pending():
        bits |= ST_ERROR
    return bits


def actual_value_readers(axis: StatusAxis) -> dict[tuple[int, int], Callable[[], int]]:
    """The readers of the actual values by (index, sub-index): position increments 0x2030,
    0x6064 and 0x606C in the CiA 402 factors, and the ACTUAL list 0x2070."""
    units = axis.units
    readers: dict[tuple[int, int], Callable[[], int]] = {
        (POSITION_INCREMENTS, 0): lambda: wrap_int32(axis.p * units.prbase_scale()),
        (obj.POSITION_ACTUAL, 0): lambda: wrap_int32(units.counts_to_position_units(axis.p)),
        (obj.VELOCITY_ACTUAL, 0): lambda: wrap_int32(units.counts_to_velocity_units(axis.v)),
    }
    actual: dict[int, Callable[[], int]] = {
        1: lambda: int(axis.p) & 0xFFFFFF,
        2: lambda: int(round(axis.v / 125.0)),
        3: lambda: wrap_int32(axis.p * units.actual_scale()),
        6: lambda: wrap_int32(units.counts_to_user(axis.p)),
        7: lambda: wrap_int32(units.counts_to_user(axis.v)),
        8: lambda: wrap_int32(units.counts_to_user(axis.dp - axis.p)),
        9: lambda: int(abs(axis.torque) * RATED_CURRENT_MA / 1000.0),
        10: lambda: int(round(axis.v * 60.0 / COUNTS_PER_REV)),
        0x11: axis.extended_status,
        0x13: lambda: wrap_int32(axis.dp * units.prbase_scale()),
        0x16: lambda: int(axis.star.errcode()),
        0x17: lambda: wrap_int32(axis.dv * SAMPLE),
    }
    readers.update({(ACTUAL, sub): reader for sub, reader in actual.items()})
    return readers
