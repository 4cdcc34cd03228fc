"""The Kollmorgen AKD's ASCII parameters as the bridge and the simulated AKD know them: the table
read from the shipped file (shared/drives/akd.md §8.3, §1.6).

The table (:data:`AKD_PARAMETERS`) is every ASCII parameter the report's object dictionary
(§8.3) and §1.6 name, with its object, data type and scaling ("1000:1": the SDO value is
1000 x the ASCII value), access as printed (blank = "rw"), unit and flags (volatile, restart,
choices). It is read from the shipped file :data:`ASCII_TABLE` (families/akd/data/
akd_ascii_parameters.txt, one parameter a line; its header names the sources), which the
simulated AKD reads too, as both read akd.eds (:func:`read_parameter_table`; each reader names
the user units its own way). What the bridge makes of a row:

- **range**: what the parameter's CANopen object can carry, i.e. its data type's range
  divided by the scaling (INT32 1:1 -> -2147483648..2147483647; UNSIGNED32 1000:1 ->
  0..4294967.295). The manual prints no other ranges, except the choices of FBUS.PARAM01
  (0, 125, 250, 500, 1000: §1.2) and the on/off switches FBUS.PARAM02 / 04 (§1.6). The
  drive checks its own, narrower, limits and answers with an error text;
- **type**: parameters without scaling are integers; scaled ones take up to 3 decimals;
- **unit**: the unit class the report gives (position / velocity / acceleration in the
  user units of UNIT.PROTARY / VROTARY / ACCROTARY, §7.1), A for the 1000:1 currents (§7.4),
  and the units named in §8.3 (Ohm, ns, Hz); the unit the drive prints wins when it prints one;
- **save_needed**: writable parameters live in RAM until DRV.NVSAVE; NMT reset node and
  power-off discard unsaved values (§10.14), so every writable parameter needs a save,
  except the run-time values marked volatile (AOUT.VALUEU, MT.NUM, PLS.RESET, ...).
  FBUS.PARAM01 (bit rate) takes effect only after a save and a 24 V restart (§1.2).
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

from drive_bridge.resources import family_data

INT_RANGES = {
    'i8': (-(1 << 7), (1 << 7) - 1), 'i16': (-(1 << 15), (1 << 15) - 1), 'i32': (-(1 << 31), (1 << 31) - 1),
    'u8': (0, (1 << 8) - 1), 'u16': (0, (1 << 16) - 1), 'u32': (0, (1 << 32) - 1), 'u64': (0, (1 << 64) - 1),
}
UNITS = {'pos': 'position units', 'vel': 'velocity units', 'acc': 'acceleration units'}

@dataclass(frozen=True)
class AkdParameter:
    """One row of the table: see the module docstring."""

    name: str
    index: int  # CANopen object (0: none)
    subindex: int
    kind: str  # i8 .. u64, 'text' (read-only text), 'cmd' (a command without value)
    scale: int  # 0: integer (no scaling); 1: "1:1"; 1000: "1000:1"; -1: "var"
    access: str  # 'rw', 'ro', 'wo', 'cmd'
    unit: str
    volatile: bool = False  # a run-time value DRV.NVSAVE does not keep
    restart: bool = False  # takes effect only after DRV.NVSAVE and a 24 V restart
    choices: tuple[int, ...] = ()

    @property
    def numeric(self) -> bool:
        return self.kind in INT_RANGES

    @property
    def limits(self) -> tuple[Decimal, Decimal] | None:
        """The range of the parameter's object, in ASCII units (None: not a number, or "var")."""
        if not self.numeric or self.scale < 0:
            return None
        low, high = INT_RANGES[self.kind]
        scale = max(1, self.scale)
        return Decimal(low) / scale, Decimal(high) / scale

    @property
    def save_needed(self) -> bool:
        return self.access == 'rw' and not self.volatile

    @property
    def note(self) -> str:
        if self.restart:
            return 'takes effect only after DRV.NVSAVE and a 24 V restart'
        return ''


ASCII_TABLE = family_data('akd', 'akd_ascii_parameters.txt')  # the manual's facts, read by the bridge and the simulator
_SCALES = {'-': 0, '1': 1, '1000': 1000, 'var': -1}
_KINDS = frozenset(INT_RANGES) | {'text', 'cmd'}
_ACCESS = frozenset({'rw', 'ro', 'wo', 'cmd'})
_OBJECT = re.compile(r'([0-9A-F]{1,4}):(\d{1,3})')


def parse_parameter_row(line: str, units: Mapping[str, str], where: str = 'row') -> AkdParameter:
    """One line of the table file (``name index:sub type scaling access unit [flags]``, see its
    header), the unit through ``units`` ('pos', 'vel', 'acc': the user units; '-': none).
    ValueError naming ``where`` for a line that is not one."""
    fields = line.split()
    if len(fields) < 6:
        raise ValueError(f'{where}: {line!r} has {len(fields)} of the 6 columns name object type scaling access unit')
    name, obj, kind, scaling, access, unit, *flags = fields
    problems = [f'{what} {text!r} is not one of {", ".join(sorted(known))}'
                for what, text, known in (('type', kind, _KINDS), ('scaling', scaling, _SCALES),
                                          ('access', access, _ACCESS)) if text not in known]
    place = _OBJECT.fullmatch(obj)
    if place is None:
        problems.insert(0, f'object {obj!r} is not INDEX:SUB (hex index, decimal sub-index)')
    choices: tuple[int, ...] = ()
    for flag in flags:
        if flag.startswith('choices=') and re.fullmatch(r'-?\d+(?:/-?\d+)*', flag[len('choices='):]):
            choices = tuple(int(c) for c in flag[len('choices='):].split('/'))
        elif flag not in ('v', 'r'):
            problems.append(f'flag {flag!r} is not v, r or choices=a/b/c')
    if problems or place is None:
        raise ValueError(f'{where}: {line.strip()!r}: {"; ".join(problems)}')
    return AkdParameter(name, int(place.group(1), 16), int(place.group(2)), kind, _SCALES[scaling], access,
                        '' if unit == '-' else units.get(unit, unit), volatile='v' in flags, restart='r' in flags,
                        choices=choices)


def read_parameter_table(units: Mapping[str, str], path: Path = ASCII_TABLE) -> dict[str, AkdParameter]:
    """Every row of the table file by name, in file order; ``units`` as for :func:`parse_parameter_row`
    (each reader names the user units its own way). ValueError for a bad line or a repeated name."""
    table: dict[str, AkdParameter] = {}
    for number, line in enumerate(path.read_text(encoding='utf-8').splitlines(), 1):
        if line.strip() and not line.lstrip().startswith('#'):
            row = parse_parameter_row(line, units, f'{path.name}:{number}')
            if row.name in table:
                raise ValueError(f'{path.name}:{number}: {row.name} is listed twice')
            table[row.name] = row
    return table


AKD_PARAMETERS: dict[str, AkdParameter] = read_parameter_table(UNITS)
