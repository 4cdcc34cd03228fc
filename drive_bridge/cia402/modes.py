"""Modes of operation (0x6060 / 0x6061) with their names and 0x6502 support bits."""
from __future__ import annotations

from enum import IntEnum


class Mode(IntEnum):
    """CiA 402 modes of operation; negative values are manufacturer-specific."""

    NO_MODE = 0
    PROFILE_POSITION = 1
    VELOCITY = 2
    PROFILE_VELOCITY = 3
    PROFILE_TORQUE = 4
    HOMING = 6
    INTERPOLATED_POSITION = 7
    CYCLIC_SYNC_POSITION = 8
    CYCLIC_SYNC_VELOCITY = 9
    CYCLIC_SYNC_TORQUE = 10


SHORT_NAMES: dict[Mode, str] = {
    Mode.NO_MODE: 'none',
    Mode.PROFILE_POSITION: 'pp',
    Mode.VELOCITY: 'vl',
    Mode.PROFILE_VELOCITY: 'pv',
    Mode.PROFILE_TORQUE: 'pt',
    Mode.HOMING: 'hm',
    Mode.INTERPOLATED_POSITION: 'ip',
    Mode.CYCLIC_SYNC_POSITION: 'csp',
    Mode.CYCLIC_SYNC_VELOCITY: 'csv',
    Mode.CYCLIC_SYNC_TORQUE: 'cst',
}

# bit of each mode in 0x6502 "supported drive modes"
SUPPORT_BITS: dict[Mode, int] = {
    Mode.PROFILE_POSITION: 0, Mode.VELOCITY: 1, Mode.PROFILE_VELOCITY: 2, Mode.PROFILE_TORQUE: 3,
    Mode.HOMING: 5, Mode.INTERPOLATED_POSITION: 6, Mode.CYCLIC_SYNC_POSITION: 7,
    Mode.CYCLIC_SYNC_VELOCITY: 8, Mode.CYCLIC_SYNC_TORQUE: 9,
}

POSITION_MODES = frozenset({Mode.PROFILE_POSITION, Mode.INTERPOLATED_POSITION, Mode.CYCLIC_SYNC_POSITION})
VELOCITY_MODES = frozenset({Mode.VELOCITY, Mode.PROFILE_VELOCITY, Mode.CYCLIC_SYNC_VELOCITY})
TORQUE_MODES = frozenset({Mode.PROFILE_TORQUE, Mode.CYCLIC_SYNC_TORQUE})
CYCLIC_MODES = frozenset({Mode.CYCLIC_SYNC_POSITION, Mode.CYCLIC_SYNC_VELOCITY, Mode.CYCLIC_SYNC_TORQUE})

_BY_NAME: dict[str, int] = {}
for _mode, _short in SHORT_NAMES.items():
    _BY_NAME[_short] = _mode
    _BY_NAME[_mode.name.lower()] = _mode
    _BY_NAME[_mode.name.lower().replace('_', ' ')] = _mode


def parse_mode(value: int | str) -> int:
    """A mode code from a number or a name ('csp', 'cyclic_sync_position', 'profile position').

    Negative numbers (manufacturer modes) are accepted as they are. Raises ValueError
    naming the accepted names.
    """
    if isinstance(value, bool):
        raise ValueError(f'mode must be a name or a number, not {value!r}')
    if isinstance(value, int):
        if -128 <= value <= 127:
            return value
        raise ValueError(f'mode {value} is outside INTEGER8')
    key = str(value).strip().lower()
    if key in _BY_NAME:
        return _BY_NAME[key]
    try:
        return parse_mode(int(key, 0))
    except ValueError:
        pass
    names = ', '.join(sorted(SHORT_NAMES.values()))
    raise ValueError(f'unknown mode {value!r}; use a number or one of: {names}')


def mode_name(code: int) -> str:
    """Short name of a mode code, 'manufacturer(-N)' for negative ones."""
    try:
        return SHORT_NAMES[Mode(code)]
    except ValueError:
        return f'manufacturer({code})' if code < 0 else f'reserved({code})'
