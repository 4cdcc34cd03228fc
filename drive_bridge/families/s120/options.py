"""An S120 axis' ``drive:`` settings: the mechanics between the motor and the joint. The drive's
own units (encoder increments, rpm, per mille of r0333) are read from the drive object at boot
(:mod:`drive_bridge.families.s120.units`), so the axis gives no ``scaling``.

=========================  =======  ===================================================
key                        default  meaning
=========================  =======  ===================================================
``gear_ratio``             1        motor revolutions per joint revolution (> 0)
``direction``              1        1 or -1: the joint's sign against the motor's
``offset``                 0        joint position (rad or m) at drive position 0
``metres_per_revolution``  (none)   a prismatic joint: metres per joint-side revolution
``encoder``                (drive)  true / false: whether the drive object has a commissioned
                                    encoder (velocity in increments/s, else rpm, §5.1); by
                                    default read from the drive: p0400[0] != 0, or where the
                                    drive has no p0400 in the window, r1300 = 21 / 23
=========================  =======  ===================================================
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from drive_bridge.families.drive_settings import parse_drive_settings

KEYS = ('gear_ratio', 'direction', 'offset', 'metres_per_revolution', 'encoder')


@dataclass(frozen=True)
class AxisOptions:
    gear_ratio: float = 1.0
    direction: int = 1
    offset: float = 0.0
    metres_per_revolution: float | None = None
    encoder: bool | None = None  # None: read from the drive

    @classmethod
    def of(cls, values: Mapping[str, Any]) -> AxisOptions:
        """From the values :func:`parse_options` returned (the joint driver's ``config.drive``)."""
        return cls(**{k: v for k, v in values.items() if k in KEYS})


def parse_options(options: Mapping[str, Any]) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """(values, [(key, problem)]) of an axis' ``drive`` mapping."""
    return parse_drive_settings(options, 'sinamics_s120', KEYS, booleans=('encoder',))
