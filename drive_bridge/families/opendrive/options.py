"""An OPEN drive axis' ``drive:`` settings: what the CAN appendix does not say
(shared/drives/opendrive.md §5 "Unknown", §7.2), given per axis, validated here.

Every constant of the drive that the appendix leaves open is a required key without a
default; a missing one is an error naming the key and what it means. The shipped example
(config/opendrive_example.yaml) gives the simulator's values.

=========================  ========  =====================================================
key                        required  meaning
=========================  ========  =====================================================
``n_max_rpm``              yes       the drive's set maximum speed n_MAX (rpm): 16384 in
                                     0x201A = n_MAX
``rated_torque``           yes       motor nominal torque T_nom (N·m): 4095 = T_nom
``pole_pairs``             yes       motor pole pairs (0x201D: 65536 x pole pairs per rev)
``pwm_frequency``          yes       f_pwm (Hz): 0x201D's time base; life time <= 32767/f_pwm s
``speed_reference``        yes       0x201A (% of n_MAX) or 0x201D (angle per PWM period)
``actual_velocity``        yes       ``{table: tab_osc | tab_int, element: 0..63}``, scaled by
                                     its word in 0x2004 / 0x2003 (100 % = n_MAX)
``actual_torque``          no        the same form, 100 % = T_nom (absent: no effort feedback)
``position``               yes       ``none`` (integrated from velocity, marked estimated) or
                                     ``{table, element, counts_per_revolution}`` (INT16, wraps)
``alarm_reset_function``   yes       number (1..31) of the standard logic input function that
                                     resets alarms: bit n of 0x201F
``array_offset``           yes       sub-index of array element k is k + offset (0 or 1)
``gear_ratio``             no        motor revolutions per joint revolution (default 1)
``direction``              no        1 or -1: joint sign against the motor (default 1)
=========================  ========  =====================================================
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from drive_bridge.families.opendrive import objects as od


@dataclass(frozen=True)
class Quantity:
    """An actual value: element ``element`` of Tab_osc (0x2012) or Tab_int (0x200F)."""

    table: str  # 'tab_osc' or 'tab_int'
    element: int

    @property
    def index(self) -> int:
        return od.TABLES[self.table]

    def key(self, array_offset: int) -> tuple[int, int]:
        return self.index, self.element + array_offset

    def describe(self, array_offset: int) -> str:
        index, sub = self.key(array_offset)
        return f'0x{index:04X}:{sub:02X} ({self.table}[{self.element}])'


@dataclass(frozen=True)
class PositionQuantity(Quantity):
    """A position-like actual value: INT16 counts, ``counts_per_revolution`` of the motor."""

    counts_per_revolution: float = 65536.0


@dataclass(frozen=True)
class DriveOptions:
    """The validated ``drive:`` settings of one axis."""

    n_max_rpm: float
    rated_torque: float
    pole_pairs: int
    pwm_frequency: float
    speed_reference: int
    actual_velocity: Quantity
    actual_torque: Quantity | None
    position: PositionQuantity | None
    alarm_reset_function: int
    array_offset: int
    gear_ratio: float = 1.0
    direction: int = 1

    @property
    def life_time_limit_ms(self) -> float:
        """The longest node life time the drive keeps: 32767 / f_pwm s, in ms."""
        return od.LIFE_TIME_CLAMP / self.pwm_frequency * 1000.0

    @classmethod
    def of(cls, values: Mapping[str, Any]) -> DriveOptions:
        """From the values :func:`parse_options` returned (ValueError naming what is missing)."""
        missing = [key for key in REQUIRED if key not in values]
        if missing:
            raise ValueError(f'the axis has no drive settings {", ".join(missing)} (see the family\'s '
                             'parse_axis_options)')
        return cls(**{key: values[key] for key in (*REQUIRED, *OPTIONAL) if key in values})


REQUIRED: dict[str, str] = {
    'n_max_rpm': "the drive's set maximum speed n_MAX in rpm (16384 in 0x201A = n_MAX), e.g. 3000",
    'rated_torque': 'the motor nominal torque T_nom in N·m (4095 in 0x201C = T_nom), e.g. 10.0',
    'pole_pairs': 'the motor pole pairs (0x201D counts 65536 x pole pairs per revolution), e.g. 4',
    'pwm_frequency': 'the PWM frequency f_pwm in Hz (time base of 0x201D; the node life time is '
                     'clamped to 32767 / f_pwm s), e.g. 8000',
    'speed_reference': 'the speed reference object: 0x201A (16384 = n_MAX) or 0x201D (electrical '
                       'angle per PWM period)',
    'actual_velocity': 'where the actual speed is: {table: tab_osc or tab_int, element: 0..63} '
                       '(scaled by its representation word in 0x2004 / 0x2003: 100 % = n_MAX)',
    'position': "where a position is: none (integrated from the velocity and marked estimated) or "
                "{table: tab_osc or tab_int, element: 0..63, counts_per_revolution: 65536}",
    'alarm_reset_function': 'the number (1..31) of the standard logic input function that resets '
                            'alarms (bit n of 0x201F), e.g. 5',
    'array_offset': 'the sub-index offset of array elements: element k is at sub-index k + '
                    'array_offset (0 or 1)',
}
OPTIONAL: dict[str, str] = {
    'actual_torque': '{table: tab_osc or tab_int, element: 0..63} (its representation word: 100 % = T_nom)',
    'gear_ratio': 'motor revolutions per joint revolution (> 0, default 1)',
    'direction': '1 or -1 (default 1)',
}
UNKNOWN_NOTE = 'the CAN appendix does not give it (shared/drives/opendrive.md §5)'


def _describe(value: Any) -> str:
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, Mapping):
        return 'a mapping'
    if isinstance(value, (list, tuple)):
        return 'a list'
    return 'null' if value is None else str(value)


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def _integer(value: Any) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return None


def _index(value: Any) -> int | None:
    """0x201A as YAML reads it (an int), or a text '0x201A' / '201Ah'."""
    number = _integer(value)
    if number is not None:
        return number
    if isinstance(value, str):
        text = value.strip().lower()
        try:
            return int(text[:-1], 16) if text.endswith('h') else int(text, 0)
        except ValueError:
            return None
    return None


class _Parser:
    def __init__(self) -> None:
        self.problems: list[tuple[str, str]] = []

    def error(self, key: str, message: str) -> None:
        self.problems.append((key, message))

    def positive(self, key: str, value: Any, unit: str) -> float | None:
        number = _number(value)
        if number is None or number <= 0:
            self.error(key, f'expected a number > 0 ({unit}), got {_describe(value)}')
            return None
        return number

    def integer(self, key: str, value: Any, low: int, high: int, what: str) -> int | None:
        number = _integer(value)
        if number is None or not low <= number <= high:
            self.error(key, f'expected {what} {low}..{high}, got {_describe(value)}')
            return None
        return number

    def quantity(self, key: str, value: Any, position: bool = False) -> Quantity | None:
        allowed = ('table', 'element', 'counts_per_revolution') if position else ('table', 'element')
        form = ('{table: tab_osc or tab_int, element: 0..63' + (', counts_per_revolution: > 0}' if position else '}'))
        if not isinstance(value, Mapping):
            self.error(key, f'expected {form}, got {_describe(value)}')
            return None
        for extra in (k for k in value if k not in allowed):
            self.error(key, f'unknown key {extra!r} (expected {", ".join(allowed)})')
        table = value.get('table')
        if table not in od.TABLES:
            self.error(key, f'table: expected tab_osc (0x2012) or tab_int (0x200F), got {_describe(table)}')
        element = _integer(value.get('element'))
        if element is None or not 0 <= element < od.TABLE_ELEMENTS:
            self.error(key, f'element: expected an element number 0..{od.TABLE_ELEMENTS - 1}, '
                            f'got {_describe(value.get("element"))}')
        if not position:
            return Quantity(str(table), element) if table in od.TABLES and element is not None else None
        counts = _number(value.get('counts_per_revolution'))
        if counts is None or counts <= 0:
            self.error(key, f'counts_per_revolution: expected a number > 0 (INT16 counts per motor revolution, '
                            f'e.g. 65536), got {_describe(value.get("counts_per_revolution"))}')
        if table not in od.TABLES or element is None or counts is None or counts <= 0:
            return None
        return PositionQuantity(str(table), element, counts)


def parse_options(options: Mapping[str, Any]) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """(values by key, [(key, error message)]): see the module docstring for the keys."""
    parser = _Parser()
    values: dict[str, Any] = {}
    known = (*REQUIRED, *OPTIONAL)
    for key in options:
        if key not in known:
            parser.error(key, f"unknown OPEN drive axis setting; known: {', '.join(known)}")
    for key, meaning in REQUIRED.items():
        if key not in options:
            parser.error(key, f'required: {meaning}; {UNKNOWN_NOTE}')
    get = options.get
    checks: dict[str, Any] = {}
    if 'n_max_rpm' in options:
        checks['n_max_rpm'] = parser.positive('n_max_rpm', get('n_max_rpm'), 'rpm')
    if 'rated_torque' in options:
        checks['rated_torque'] = parser.positive('rated_torque', get('rated_torque'), 'N·m')
    if 'pole_pairs' in options:
        checks['pole_pairs'] = parser.integer('pole_pairs', get('pole_pairs'), 1, 255, 'a pole pair count')
    if 'pwm_frequency' in options:
        checks['pwm_frequency'] = parser.positive('pwm_frequency', get('pwm_frequency'), 'Hz')
    if 'speed_reference' in options:
        index = _index(get('speed_reference'))
        if index not in od.SPEED_REFERENCES:
            parser.error('speed_reference', 'expected 0x201A (f_fieldbus, 16384 = n_MAX) or 0x201D '
                                            f'(theta_fieldbus), got {_describe(get("speed_reference"))}')
        checks['speed_reference'] = index if index in od.SPEED_REFERENCES else None
    if 'actual_velocity' in options:
        checks['actual_velocity'] = parser.quantity('actual_velocity', get('actual_velocity'))
    if 'actual_torque' in options and get('actual_torque') is not None:
        checks['actual_torque'] = parser.quantity('actual_torque', get('actual_torque'))
    elif 'actual_torque' in options:
        values['actual_torque'] = None
    if 'position' in options:
        raw = get('position')
        if raw is None or (isinstance(raw, str) and raw.strip().lower() == 'none'):
            values['position'] = None
        else:
            checks['position'] = parser.quantity('position', raw, position=True)
    if 'alarm_reset_function' in options:
        checks['alarm_reset_function'] = parser.integer(
            'alarm_reset_function', get('alarm_reset_function'), 1, 31,
            'a standard logic input function number (0 is RUN)')
    if 'array_offset' in options:
        offset = _integer(get('array_offset'))
        if offset not in (0, 1):
            parser.error('array_offset', f'expected 0 or 1, got {_describe(get("array_offset"))}')
        checks['array_offset'] = offset if offset in (0, 1) else None
    if 'gear_ratio' in options:
        checks['gear_ratio'] = parser.positive('gear_ratio', get('gear_ratio'), 'motor revolutions per joint '
                                                                              'revolution')
    if 'direction' in options:
        direction = _integer(get('direction'))
        if direction not in (1, -1):
            parser.error('direction', f'expected 1 or -1, got {_describe(get("direction"))}')
        checks['direction'] = direction if direction in (1, -1) else None
    values.update({key: value for key, value in checks.items() if value is not None})
    for a, b in (('actual_velocity', 'actual_torque'), ('actual_velocity', 'position'),
                 ('actual_torque', 'position')):
        first, second = values.get(a), values.get(b)
        if first is not None and second is not None and (first.table, first.element) == (second.table,
                                                                                        second.element):
            parser.error(b, f'{second.table}[{second.element}] is already {a}')
    return values, parser.problems
