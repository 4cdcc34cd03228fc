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

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

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


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def parse_options(options: Mapping[str, Any]) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """(values, [(key, problem)]) of an axis' ``drive`` mapping."""
    values: dict[str, Any] = {}
    problems: list[tuple[str, str]] = []
    for key, raw in options.items():
        if key not in KEYS:
            problems.append((key, f"unknown key for family 'servostar'; allowed keys: {', '.join(KEYS)}"))
            continue
        number = _number(raw)
        if key == 'direction':
            if number not in (1.0, -1.0):
                problems.append((key, f'expected 1 or -1, got {raw!r}'))
            else:
                values[key] = int(number or 1)
        elif key == 'offset':
            if number is None:
                problems.append((key, f'expected a number (rad or m), got {raw!r}'))
            else:
                values[key] = number
        elif number is None or number <= 0:
            problems.append((key, f'expected a number > 0, got {raw!r}'))
        else:
            values[key] = number
    return values, problems
