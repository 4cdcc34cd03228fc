"""OPEN drive parameters by number: ``P0``..``P199`` (0x200D) and ``C0``..``C99`` (0x200E), with
their format words (shared/drives/opendrive.md §3.2).

The format tables are DOMAIN objects read once per node by segmented SDO upload and kept:
0x2001 (200 x 4 words) for P, 0x2002 (100 x 4 words) for C. Each entry is four 16-bit
little-endian words: the format word, the minimum and maximum (internal units) and the base.
The format word's nibbles, from the top: class (0 not managed, 1 Free, 2 Reserved, 4 TDE),
representation (0 direct signed, 1 percent of base, 2 proportional to base, 3 direct
unsigned), integer digits, decimals.

- **read**: the element (k + the axis' ``array_offset``) as the representation reads it, in
  engineering units (percent: v * 100 / base, '%'; proportional: v / base), shown with the
  format's decimals; range from words 2-3 through the same formula; access = the class.
- **write**: the value in engineering units is turned into the internal value (rounded to
  the format's resolution) and checked before anything is sent: not-managed slots are
  refused, a value outside min..max is refused with the range in both units, a Reserved
  parameter is refused while the drive runs (RUN high, 0x2021 bit 0) and while its key P60
  is 0 (the key's value is the drive's: any other value is sent, and the drive checks it), a
  TDE parameter likewise with the key P99 (§3.2: "off-line only + key"). Then it is written
  (INT16, by SDO) and read back. The drive applies the same rules (§2.1) and may still
  refuse: its SDO abort is reported.
- **save**: C63 = 1 (the drive stores P and C in its non-volatile memory).
"""
from __future__ import annotations

import math
import re
import struct
import threading
from dataclasses import dataclass

from drive_bridge.families.errors import ParameterError
from drive_bridge.families.opendrive import objects as od
from drive_bridge.families.parameters import (
    ParameterAccess,
    ParameterPort,
    ParameterValue,
    format_limit,
    parameter_error,
)

NOT_MANAGED, FREE, RESERVED, TDE = 0, 1, 2, 4
DIRECT, PERCENT, PROPORTIONAL, UNSIGNED = 0, 1, 2, 3
CLASS_NAMES = {NOT_MANAGED: 'not managed', FREE: 'free (on-line)', RESERVED: 'reserved (off-line, key P60)',
               TDE: 'TDE (off-line, key P99)'}
KEYS = {RESERVED: od.P60, TDE: od.P99}
_NAME = re.compile(r'\s*([PpCc])\s*(\d{1,3})\s*')
_WORDS = struct.Struct('<4H')


@dataclass(frozen=True)
class Format:
    """One entry of a format table (internal units as the representation reads them)."""

    word: int
    minimum: int
    maximum: int
    base: int

    @classmethod
    def of(cls, words: tuple[int, int, int, int]) -> Format:
        word, low, high, base = words
        representation = word >> 8 & 0xF
        if representation != UNSIGNED:
            low, high = _signed(low), _signed(high)
        return cls(word, low, high, base)

    @property
    def access_class(self) -> int:
        return self.word >> 12 & 0xF

    @property
    def representation(self) -> int:
        return self.word >> 8 & 0xF

    @property
    def digits(self) -> int:
        return self.word >> 4 & 0xF

    @property
    def decimals(self) -> int:
        return self.word & 0xF

    @property
    def unit(self) -> str:
        return '%' if self.representation == PERCENT else ''

    def real(self, internal: int) -> float:
        if self.representation == PERCENT:
            return internal * 100.0 / self.base
        if self.representation == PROPORTIONAL:
            return internal / self.base
        return float(internal)

    def internal(self, real: float) -> int:
        if self.representation == PERCENT:
            return round(real * self.base / 100.0)
        if self.representation == PROPORTIONAL:
            return round(real * self.base)
        return round(real)

    def from_raw(self, raw: bytes) -> int:
        value = int.from_bytes(raw[:2].ljust(2, b'\0'), 'little')
        return value if self.representation == UNSIGNED else _signed(value)

    def text(self, real: float) -> str:
        return f'{real:.{self.decimals}f}'

    @property
    def scaled(self) -> bool:
        return self.representation in (PERCENT, PROPORTIONAL)


def _signed(value: int) -> int:
    value &= 0xFFFF
    return value - 0x10000 if value >= 0x8000 else value


# node id and bit rate: the parameters that change the drive's link (appendix §1)
SAFETY_PARAMETERS = {('P', 162): 'P162, the CAN node id', ('C', 48): 'C48, the CAN bit rate code'}


def parse_name(name: str) -> tuple[str, int] | None:
    """('P', 162) for 'P162' / 'p 162'; None if it is not a P or C number."""
    match = _NAME.fullmatch(name)
    return (match.group(1).upper(), int(match.group(2))) if match else None


class OpenDriveParameters(ParameterAccess):
    """The P and C parameters of one node."""

    def __init__(self, port: ParameterPort, array_offset: int) -> None:
        self.port = port
        self.array_offset = array_offset
        self._lock = threading.Lock()
        self._tables: dict[str, tuple[Format, ...]] = {}

    # -- ParameterAccess ----------------------------------------------------------------------------
    def read(self, name: str, drive_object: int = 0) -> ParameterValue:
        label, letter, number = self._name(name, drive_object)
        with self._lock:
            spec = self._format(label, letter, number)
            return self._value(label, spec, self._read_internal(label, letter, number, spec))

    def write(self, name: str, value_text: str, drive_object: int = 0) -> ParameterValue:
        label, letter, number = self._name(name, drive_object)
        with self._lock:
            spec = self._format(label, letter, number)
            internal = self._checked(label, spec, value_text.strip())
            self._check_class(label, spec)
            data = (internal & 0xFFFF).to_bytes(2, 'little')
            try:
                self.port.sdo_write_raw(*self._address(letter, number), data)
            except Exception as exc:  # the port's SDO error, whatever its type
                raise self._error(label, f'the drive refused {value_text.strip()} (internal {internal}): {exc}',
                                  drive_text=str(exc)) from exc
            return self._value(label, spec, self._read_internal(label, letter, number, spec))

    def stores(self, name: str) -> bool:
        return parse_name(name.strip()) == ('C', od.C63)

    def safety(self, name: str) -> str | None:
        parsed = parse_name(name.strip())
        return SAFETY_PARAMETERS.get(parsed) if parsed is not None else None

    def save(self, drive_object: int = 0) -> str:
        self._name('C63', drive_object)
        with self._lock:
            try:
                self.port.sdo_write_raw(*self._address('C', od.C63), (1).to_bytes(2, 'little'))
            except Exception as exc:
                raise self._error('C63', f'save (C63 = 1) failed: {exc}', drive_text=str(exc)) from exc
        return (f'C63 = 1: the parameters of node {self.port.node_id} ({self.port.name}) are stored in the '
                "drive's non-volatile memory (node id P162 and bit rate C48 apply after the drive restarts)")

    # -- helpers --------------------------------------------------------------------------------
    def _error(self, parameter: str, reason: str, drive_text: str = '') -> ParameterError:
        return parameter_error(self.port, parameter, reason, drive_text)

    def _name(self, name: str, drive_object: int) -> tuple[str, str, int]:
        parsed = parse_name(name)
        if parsed is None:
            raise self._error(name.strip(), 'an OPEN drive parameter is P0..P199 (0x200D) or C0..C99 (0x200E), '
                                            'e.g. P162 or C52')
        letter, number = parsed
        label = f'{letter}{number}'
        if drive_object != 0:
            raise self._error(label, f'an OPEN drive has one drive object: drive_object must be 0, not {drive_object}')
        count = od.P_COUNT if letter == 'P' else od.C_COUNT
        if number >= count:
            raise self._error(label, f'{letter} numbers are 0..{count - 1}')
        return label, letter, number

    def _address(self, letter: str, number: int) -> tuple[int, int]:
        return (od.PARAMETERS if letter == 'P' else od.CONNECTIONS), number + self.array_offset

    def _format(self, label: str, letter: str, number: int) -> Format:
        table = self._tables.get(letter)
        if table is None:
            index, count = (od.FORMATS_P, od.P_COUNT) if letter == 'P' else (od.FORMATS_C, od.C_COUNT)
            try:
                raw = self.port.sdo_read_raw(index, 0)
            except Exception as exc:
                raise self._error(label, f'reading the format table 0x{index:04X} failed: {exc}') from exc
            if len(raw) < 8 * count:
                raise self._error(label, f'the format table 0x{index:04X} has {len(raw)} bytes, expected '
                                         f'{8 * count} ({count} x 4 words)')
            table = tuple(Format.of(_WORDS.unpack_from(raw, 8 * k)) for k in range(count))
            self._tables[letter] = table
        spec = table[number]
        if spec.scaled and spec.base == 0:
            raise self._error(label, f'its format word 0x{spec.word:04X} scales by a base of 0')
        return spec

    def _read_internal(self, label: str, letter: str, number: int, spec: Format) -> int:
        index, sub = self._address(letter, number)
        try:
            return spec.from_raw(self.port.sdo_read_raw(index, sub))
        except Exception as exc:
            raise self._error(label, f'reading 0x{index:04X}:{sub:02X} failed: {exc}') from exc

    def _value(self, label: str, spec: Format, internal: int) -> ParameterValue:
        note = f'internal value {internal}'
        if spec.scaled:
            note += f', base {spec.base}'
        if spec.access_class == NOT_MANAGED:
            note = 'unused slot (class 0, not managed)'
        real = spec.real(internal)
        return ParameterValue(label, spec.text(real), real, spec.unit, spec.real(spec.minimum),
                              spec.real(spec.maximum), CLASS_NAMES.get(spec.access_class, f'class {spec.access_class}'),
                              save_needed=spec.access_class != NOT_MANAGED, note=note)

    def _checked(self, label: str, spec: Format, text: str) -> int:
        """The internal value to write, after the class, type and range checks."""
        if spec.access_class == NOT_MANAGED:
            raise self._error(label, 'is not managed (an unused slot of the format table): nothing to write')
        if spec.access_class not in CLASS_NAMES:
            raise self._error(label, f'has the unknown class {spec.access_class} (format word 0x{spec.word:04X})')
        try:
            real = float(text)
        except ValueError:
            raise self._error(label, f'{text!r} is not a number') from None
        if not math.isfinite(real):
            raise self._error(label, f'{text} is not a finite number')
        internal = spec.internal(real)
        if not spec.scaled and real != internal:
            raise self._error(label, f'{text} is not an integer (direct value)')
        unit = f' {spec.unit}' if spec.unit else ''
        low, high = spec.real(spec.minimum), spec.real(spec.maximum)
        if not spec.minimum <= internal <= spec.maximum:
            raise self._error(label, f'{text}{unit} is outside the range {format_limit(low)}..{format_limit(high)}'
                                     f'{unit} (internal {internal}, allowed {spec.minimum}..{spec.maximum}); '
                                     'nothing was sent')
        return internal

    def _check_class(self, label: str, spec: Format) -> None:
        """Reserved / TDE: written only off-line (RUN low) and with the key P60 / P99 set."""
        key = KEYS.get(spec.access_class)
        if key is None:
            return
        what = 'Reserved' if spec.access_class == RESERVED else 'TDE'
        if self._running(label):
            raise self._error(label, f'is a {what} parameter: it is written only off-line, and the drive is running '
                                     f'(RUN high in 0x2021 bit 0); disable the axis first (and set the key P{key}); '
                                     'nothing was sent')
        key_spec = self._format(f'P{key}', 'P', key)
        if not self._read_internal(f'P{key}', 'P', key, key_spec):
            raise self._error(label, f'is a {what} parameter: it is written only with the key P{key} set, and P{key} '
                                     f'is 0; write the key to P{key} first; nothing was sent')

    def _running(self, label: str) -> bool:
        try:
            raw = self.port.sdo_read_raw(od.INPUTS_STANDARD_RD, 0)
        except Exception as exc:
            raise self._error(label, f'reading RUN (0x2021) to check the parameter class failed: {exc}') from exc
        return bool(int.from_bytes(raw[:4].ljust(4, b'\0'), 'little') & od.RUN_BIT)
