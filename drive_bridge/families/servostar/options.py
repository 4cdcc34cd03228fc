"""A SERVOSTAR axis' ``drive:`` settings: the mechanics between the motor and the joint. The
drive's own units (2^PRBASE increments per motor revolution, 1875/262144 rpm per speed bit, per
mille of the rated torque) are read from it or fixed by the manual, so the axis gives no
``scaling``.

=========================  =======  ===================================================
key                        default  meaning
=========================  =======  ===================================================
``gear_ratio``             1        motor revolutions per joint revolution (> 0)
``direction``              1        1 or -1: the joint's sign against the motor's
``offset``                 0        joint position (rad or m) at drive position 0
``metres_per_revolution``  (none)   a prismatic joint: metres per joint-side revolution
``rated_torque``           (none)   the motor's rated torque in N·m (0x6077 is per mille of
                                    it); without it the effort is reported in multiples of
                                    the rated torque
=========================  =======  ===================================================
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

from drive_bridge.families.drive_settings import parse_drive_settings

KEYS: Final = ('gear_ratio', 'direction', 'offset', 'metres_per_revolution', 'rated_torque')


@dataclass(frozen=True)
class AxisOptions:
    gear_ratio: float = 1.0
    direction: int = 1
    offset: float = 0.0
    metres_per_revolution: float | None = None
    rated_torque: float | None = None

    @classmethod
    def of(cls, values: Mapping[str, Any]) -> AxisOptions:
        """From the values :func:`parse_options` returned (the joint driver's ``config.drive``)."""
        return cls(**{k: v for k, v in values.items() if k in KEYS})


def parse_options(options: Mapping[str, Any]) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """(values, [(key, problem)]) of an axis' ``drive`` mapping."""
    return parse_drive_settings(options, 'servostar', KEYS)
