"""SINAMICS parameters by number (``p2000``, ``r0062``, ``p1120[0]``) of any drive object, through
the parameter window 0x2000 + number and the selector p8630 (shared/drives/sinamics-s120-cbc10.md
§3; manual §2.5.3, §2.6.2.4).

The window: object 0x2000 + (number mod 10000), sub-index = the parameter index mod 256. What it
shows is chosen by p8630 (object 0x41B6): [0] the drive object (1 = the Control Unit, else the
DO number as p8743 lists it), [1] the sub-index page (index // 256, 0..3), [2] the thousands range
(number // 10000, 0..5). The selector is one global, stateful switch of the node's SDO server, so
here **selection and access are one transaction** under a lock per node (:class:`ParameterChannel`,
shared by the boot steps and ``~/param_read`` / ``~/param_write``): two callers asking two DOs at
once each get their own DO's value. The three selector entries are written before every access
(a cached selection would be wrong after the drive restarted), and a page or range other than 0 is
set back to 0 afterwards. Accesses from outside the bridge (another SDO client, ``~/sdo_write`` to
0x41B6) are not serialised with these.

Values: the SDO carries the parameter's own data type, which the manual does not list; the table
:data:`PARAMETERS` gives the type, unit and meaning of the parameters the bridge and the facts file
use (types from the SINAMICS list manual, [B]: to be checked there). Another number is read by the
length the drive answers (1, 2 or 4 bytes, shown as an unsigned integer, the REAL32 reading in the
note) and written with the length read back first (an integer, or REAL32 for a value with a
decimal point). ``r`` parameters are read-only; a written ``p`` parameter lives in RAM until
``~/param_save`` (0x1010:1 = "save": every drive object of the CU to the memory card, as p0977 = 1).

``drive_object`` 0 means the joint's own drive object (p8743[slot], through :meth:`for_slot`
when the request names a joint), else that of the node's first configured axis.
"""
from __future__ import annotations

import math
import re
import struct
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from drive_bridge.families.errors import ParameterError
from drive_bridge.families.parameters import (
    ParameterAccess,
    ParameterPort,
    ParameterValue,
    format_limit,
    parameter_error,
)
from drive_bridge.families.s120 import objects as s

_NAME = re.compile(r'\s*([pPrR])\s*(\d{1,5})\s*(?:(?:\[\s*(\d{1,4})\s*\])|(?:\.\s*(\d{1,4})))?\s*')
_FORMATS = {'u8': '<B', 'i8': '<b', 'u16': '<H', 'i16': '<h', 'u32': '<I', 'i32': '<i', 'f32': '<f'}
_SIZES = {kind: struct.calcsize(fmt) for kind, fmt in _FORMATS.items()}
_RANGES = {'u8': (0, 0xFF), 'i8': (-0x80, 0x7F), 'u16': (0, 0xFFFF), 'i16': (-0x8000, 0x7FFF),
           'u32': (0, 0xFFFFFFFF), 'i32': (-0x80000000, 0x7FFFFFFF), 'f32': (-3.4028234e38, 3.4028234e38)}
_UNSIGNED_BY_SIZE = {1: 'u8', 2: 'u16', 4: 'u32'}
SAVE_DATA = struct.pack('<I', s.SAVE_SIGNATURE)


@dataclass(frozen=True)
class ParameterName:
    """A parsed name: letter (p settable, r display), number, index (None: not given)."""

    letter: str
    number: int
    index: int | None = None

    @property
    def label(self) -> str:
        return f'{self.letter}{self.number:04d}' + (f'[{self.index}]' if self.index is not None else '')

    @property
    def address(self) -> tuple[int, int, int, int]:
        """(range p8630[2], page p8630[1], object, sub-index)."""
        index = self.index or 0
        return (self.number // s.PARAMETER_WINDOW, index // s.PAGE_SIZE,
                s.PARAMETER_BASE + self.number % s.PARAMETER_WINDOW, index % s.PAGE_SIZE)


# the CBC10's parameters that set its reaction to a lost master or its link (manual: p86xx)
SAFETY_PARAMETERS = {
    8641: 'p8641, the drive reaction to a CAN communication error (= 0x6007)',
    8602: 'p8602, the SYNC COB-ID (= 0x1005)',
    8604: 'p8604, node guarding: guard time and life time factor (= 0x100C, 0x100D)',
    8606: 'p8606, the producer heartbeat time (= 0x1017)',
    8609: 'p8609, the NMT error behaviour (= 0x1029)',
    8620: 'p8620, the CAN node id',
    8622: 'p8622, the CAN bit rate',
}


def sdo_index(number: int) -> int:
    """The SDO index of a p8xxx parameter (0x4000 + number - 8192: p8620 = 0x41AC)."""
    return 0x4000 + number - 8192


def parse_name(text: str) -> ParameterName | None:
    """'p2000', 'r0062', 'p1120[0]', 'P1120.1' -> ParameterName; None if it is not one."""
    match = _NAME.fullmatch(text)
    if match is None:
        return None
    index = match.group(3) if match.group(3) is not None else match.group(4)
    return ParameterName(match.group(1).lower(), int(match.group(2)), int(index) if index is not None else None)


@dataclass(frozen=True)
class ParameterSpec:
    """What the family knows of one parameter."""

    letter: str  # 'p' (settable) or 'r' (display)
    kind: str  # u8 .. i32, f32
    unit: str
    text: str
    indexed: int = 0  # number of indices (0: not indexed)


def _spec(letter: str, kind: str, unit: str, text: str, indexed: int = 0) -> ParameterSpec:
    return ParameterSpec(letter, kind, unit, text, indexed)


PARAMETERS: dict[int, ParameterSpec] = {
    9: _spec('p', 'u16', '', 'device commissioning parameter filter (3: device configuration)'),
    18: _spec('r', 'u32', '', 'firmware version (= 0x100A)'),
    20: _spec('r', 'f32', 'rpm', 'speed setpoint, smoothed'),
    26: _spec('r', 'f32', 'V', 'DC link voltage, smoothed'),
    27: _spec('r', 'f32', 'A', 'absolute actual current, smoothed'),
    31: _spec('r', 'f32', 'N·m', 'actual torque, smoothed'),
    32: _spec('r', 'f32', 'kW', 'active power, smoothed'),
    35: _spec('r', 'f32', '°C', 'motor temperature'),
    61: _spec('r', 'f32', 'rpm', 'actual speed, encoder (= 0x6069)', 2),
    62: _spec('r', 'f32', 'rpm', 'speed setpoint'),
    63: _spec('r', 'f32', 'rpm', 'actual speed (= 0x606C)'),
    79: _spec('r', 'f32', 'N·m', 'total torque setpoint (= 0x6074)'),
    80: _spec('r', 'f32', 'N·m', 'actual torque (= 0x6077)'),
    108: _spec('p', 'u32', '', 'function modules (bit 4: simple positioner EPOS)'),
    311: _spec('p', 'f32', 'rpm', 'rated motor speed'),
    333: _spec('r', 'f32', 'N·m', 'rated motor torque (0x6071 / 0x6077 are per mille of it)'),
    400: _spec('p', 'u32', '', 'encoder type selection (0: no encoder)', 3),
    408: _spec('p', 'u32', '', 'rotary encoder pulse number', 3),
    418: _spec('p', 'u8', 'bit', 'fine resolution Gx_XIST1', 3),
    482: _spec('r', 'u32', '', 'encoder actual position value Gn_XIST1 (= 0x6063)', 3),
    640: _spec('p', 'f32', 'A', 'current limit'),
    945: _spec('r', 'u16', '', 'fault code', 64),
    947: _spec('r', 'u16', '', 'fault number', 64),
    949: _spec('r', 'i32', '', 'fault value', 64),
    976: _spec('p', 'u16', '', 'reset and load all parameters'),
    977: _spec('p', 'u16', '', 'save all parameters'),
    1070: _spec('p', 'u32', '', 'main setpoint (BICO source)'),
    1080: _spec('p', 'f32', 'rpm', 'minimum speed'),
    1082: _spec('p', 'f32', 'rpm', 'maximum speed'),
    1120: _spec('p', 'f32', 's', 'ramp-function generator ramp-up time'),
    1121: _spec('p', 'f32', 's', 'ramp-function generator ramp-down time'),
    1135: _spec('p', 'f32', 's', 'OFF3 ramp-down time'),
    1170: _spec('r', 'f32', 'rpm', 'speed controller setpoint sum'),
    1300: _spec('p', 'i16', '', 'open-loop/closed-loop control mode (= 0x6060)'),
    1520: _spec('p', 'f32', 'N·m', 'torque limit, upper/motoring'),
    2000: _spec('p', 'f32', 'rpm', 'reference speed'),
    2003: _spec('p', 'f32', 'N·m', 'reference torque'),
    2110: _spec('r', 'u16', '', 'alarm number', 64),
    2122: _spec('r', 'u16', '', 'alarm code', 64),
    8602: _spec('p', 'u32', '', 'SYNC COB-ID (= 0x1005)'),
    8603: _spec('p', 'u32', '', 'EMCY COB-ID (= 0x1014)'),
    8604: _spec('p', 'u16', '', 'node guarding: [0] guard time ms, [1] life time factor (= 0x100C/0x100D)', 2),
    8606: _spec('p', 'u16', 'ms', 'producer heartbeat time (= 0x1017)'),
    8609: _spec('p', 'u32', '', 'NMT error behaviour (= 0x1029)', 2),
    8620: _spec('p', 'u8', '', 'CAN node ID (applies after POWER ON)'),
    8630: _spec('p', 'u16', '', 'parameter window selector: [0] DO, [1] page, [2] range', 3),
    8641: _spec('p', 'i16', '', 'CAN fault reaction (0 none, 1 OFF1, 2 OFF2, 3 OFF3; = 0x6007)'),
    8684: _spec('p', 'u8', '', 'NMT state after start-up (4 stopped, 5 operational, 127 pre-operational)'),
    8685: _spec('p', 'u8', '', 'NMT state display / set'),
    8743: _spec('r', 'u16', '', 'DO number per axis slot', 8),
    8784: _spec('r', 'u16', '', 'CBC status word (= 0x6041)'),
    8791: _spec('p', 'i16', '', 'halt option code (= 0x605D)'),
    8795: _spec('r', 'u16', '', 'CBC control word (= 0x6040)'),
    8798: _spec('p', 'u32', '', 'CBC velocity conversion factor (= 0x6094)', 2),
    8848: _spec('p', 'f32', 'ms', 'CAN sampling time (IF2 PZD)'),
}


@dataclass
class ParameterChannel:
    """The parameter window of one node: a transaction (selection + access) at a time."""

    lock: threading.Lock = field(default_factory=threading.Lock)


_CHANNELS: dict[tuple[int, str], ParameterChannel] = {}
_CHANNELS_GUARD = threading.Lock()


def channel(port: ParameterPort) -> ParameterChannel:
    with _CHANNELS_GUARD:
        return _CHANNELS.setdefault((port.node_id, port.name), ParameterChannel())


def _select(port: ParameterPort, drive_object: int, page: int, window: int) -> None:
    for sub, value in ((s.SELECT_DO, drive_object), (s.SELECT_PAGE, page), (s.SELECT_RANGE, window)):
        port.sdo_write_raw(s.SELECTOR, sub, struct.pack('<H', value))


@contextmanager
def selected(port: ParameterPort, drive_object: int, name: ParameterName) -> Iterator[tuple[int, int]]:
    """Hold the node's channel with ``name`` of ``drive_object`` selected; yields (object, sub).
    Raises whatever the port raises."""
    window, page, index, sub = name.address
    with channel(port).lock:
        _select(port, drive_object, page, window)
        try:
            yield index, sub
        finally:
            if page or window:
                try:
                    port.sdo_write_raw(s.SELECTOR, s.SELECT_PAGE, struct.pack('<H', 0))
                    port.sdo_write_raw(s.SELECTOR, s.SELECT_RANGE, struct.pack('<H', 0))
                except Exception:  # the access's own outcome is what the caller needs
                    pass


def read_raw(port: ParameterPort, drive_object: int, name: ParameterName) -> bytes:
    with selected(port, drive_object, name) as (index, sub):
        return port.sdo_read_raw(index, sub)


def write_raw(port: ParameterPort, drive_object: int, name: ParameterName, data: bytes) -> None:
    with selected(port, drive_object, name) as (index, sub):
        port.sdo_write_raw(index, sub, data)


def decode(kind: str, data: bytes) -> int | float:
    size = _SIZES[kind]
    if len(data) < size:
        raise ValueError(f'{len(data)} byte(s), {kind.upper()} needs {size}')
    return struct.unpack(_FORMATS[kind], data[:size])[0]  # type: ignore[no-any-return]


def read_number(port: ParameterPort, drive_object: int, number: int, index: int | None = None) -> int | float:
    """One parameter as a number, typed by :data:`PARAMETERS` (else by its length); raises the
    port's error or ValueError (a reply that does not fit)."""
    name = ParameterName(PARAMETERS[number].letter if number in PARAMETERS else 'p', number, index)
    data = read_raw(port, drive_object, name)
    spec = PARAMETERS.get(number)
    kind = spec.kind if spec is not None else _UNSIGNED_BY_SIZE.get(len(data), 'u32')
    return decode(kind, data)


def _text(value: int | float) -> str:
    if isinstance(value, float):
        return f'{value:.6g}' if math.isfinite(value) else str(value)
    return str(value)


class S120Parameters(ParameterAccess):
    """The SINAMICS parameters of one node, any drive object."""

    def __init__(self, port: ParameterPort, drive_object_of: Callable[[int | None], int],
                 slot: int | None = None) -> None:
        """``drive_object_of(slot)``: the DO number of an axis slot (None: the node's first axis)."""
        self.port = port
        self._drive_object_of = drive_object_of
        self.slot = slot

    def for_slot(self, slot: int) -> S120Parameters:
        """The same parameters with ``drive_object`` 0 meaning the DO of axis ``slot``."""
        return S120Parameters(self.port, self._drive_object_of, slot)

    # -- ParameterAccess ----------------------------------------------------------------------------
    def read(self, name: str, drive_object: int = 0) -> ParameterValue:
        parsed, spec = self._name(name)
        do = self._drive_object(parsed, drive_object)
        data = self._transfer(parsed, do, 'reading', None)
        return self._value(parsed, spec, do, data)

    def write(self, name: str, value_text: str, drive_object: int = 0) -> ParameterValue:
        parsed, spec = self._name(name)
        do = self._drive_object(parsed, drive_object)
        if parsed.letter == 'r' or (spec is not None and spec.letter == 'r'):
            raise self._error(parsed, f'is a display parameter (r{parsed.number:04d}): read-only; nothing was sent')
        text = value_text.strip()
        kind = spec.kind if spec is not None else self._kind_by_length(parsed, do, text)
        data = self._encode(parsed, kind, text)
        self._transfer(parsed, do, f'writing {text} to', data)
        return self.read(name, do)

    def stores(self, name: str) -> bool:
        parsed = parse_name(name.strip())
        return parsed is not None and parsed.number in s.STORE_NUMBERS

    def safety(self, name: str) -> str | None:
        parsed = parse_name(name.strip())
        return SAFETY_PARAMETERS.get(parsed.number) if parsed is not None else None

    def save(self, drive_object: int = 0) -> str:
        try:
            self.port.sdo_write_raw(s.STORE_PARAMETERS, 1, SAVE_DATA)
        except Exception as exc:  # the port's SDO error, whatever its type
            raise parameter_error(self.port, '0x1010:01', f'save ("save" to 0x1010:01) failed: {exc}',
                                  str(exc)) from exc
        scope = ' (the save covers every drive object of the Control Unit, not only DO ' \
                f'{drive_object})' if drive_object else ''
        return (f'0x1010:01 = "save" (as p0977 = 1): the parameters of every drive object of node '
                f'{self.port.node_id} ({self.port.name}) are stored on the memory card{scope}')

    # -- helpers ------------------------------------------------------------------------------------
    def _error(self, name: ParameterName | str, reason: str, drive_text: str = '') -> ParameterError:
        label = name.label if isinstance(name, ParameterName) else name
        return parameter_error(self.port, label, reason, drive_text)

    def _name(self, name: str) -> tuple[ParameterName, ParameterSpec | None]:
        parsed = parse_name(name)
        if parsed is None:
            raise self._error(name.strip(), 'a SINAMICS parameter is p or r and its number, optionally with an '
                                            'index: p2000, r0062, p1120[0]')
        if parsed.number >= s.PARAMETER_WINDOW * (s.MAX_RANGE + 1):
            raise self._error(parsed, f'parameter numbers are 0..{s.PARAMETER_WINDOW * (s.MAX_RANGE + 1) - 1}')
        if parsed.index is not None and parsed.index >= s.PAGE_SIZE * (s.MAX_PAGE + 1):
            raise self._error(parsed, f'the parameter window reaches indices 0..{s.PAGE_SIZE * (s.MAX_PAGE + 1) - 1}')
        spec = PARAMETERS.get(parsed.number)
        if spec is not None and spec.indexed and parsed.index is not None and parsed.index >= spec.indexed:
            raise self._error(parsed, f'has {spec.indexed} indices (0..{spec.indexed - 1})')
        return parsed, spec

    def _drive_object(self, name: ParameterName, drive_object: int) -> int:
        if drive_object:
            return drive_object
        whose = "the node's first axis" if self.slot is None else f'the axis in slot {self.slot}'
        try:
            return self._drive_object_of(self.slot)
        except Exception as exc:
            raise self._error(name, f'drive_object 0 means the drive object of {whose}, which is unknown: {exc}; '
                                    'give drive_object (1 = the Control Unit)') from exc

    def _transfer(self, name: ParameterName, drive_object: int, what: str, data: bytes | None) -> bytes:
        window, page, index, sub = name.address
        where = (f'0x{index:04X}:{sub:02X} with p8630 = [{drive_object}, {page}, {window}]')
        try:
            if data is None:
                return read_raw(self.port, drive_object, name)
            write_raw(self.port, drive_object, name, data)
            return b''
        except Exception as exc:
            raise self._error(name, f'{what} DO {drive_object} ({where}) failed: {exc}', str(exc)) from exc

    def _kind_by_length(self, name: ParameterName, drive_object: int, text: str) -> str:
        """An unlisted parameter's type for a write: its length as read back, REAL32 for a
        4-byte value written with a decimal point or exponent."""
        length = len(self._transfer(name, drive_object, 'reading (to learn its size)', None))
        if length == 4 and re.search(r'[.eE]', text):
            return 'f32'
        kind = _UNSIGNED_BY_SIZE.get(length)
        if kind is None:
            raise self._error(name, f'is not in the family table and the drive answers {length} bytes: '
                                    'cannot tell how to write it')
        if text.strip().startswith('-'):
            return kind.replace('u', 'i')
        return kind

    def _encode(self, name: ParameterName, kind: str, text: str) -> bytes:
        if not text:
            raise self._error(name, 'no value given')
        try:
            number = float(text) if kind == 'f32' else int(text, 0)
        except ValueError:
            what = 'a number' if kind == 'f32' else f'an integer ({kind.upper()})'
            raise self._error(name, f'{text!r} is not {what}; nothing was sent') from None
        low, high = _RANGES[kind]
        if not (math.isfinite(number) and low <= number <= high):
            raise self._error(name, f'{text} is outside {kind.upper()} {format_limit(low)}..{format_limit(high)}; '
                                    'nothing was sent')
        return struct.pack(_FORMATS[kind], number)

    def _value(self, name: ParameterName, spec: ParameterSpec | None, drive_object: int,
               data: bytes) -> ParameterValue:
        if spec is not None:
            try:
                value = decode(spec.kind, data)
            except ValueError as exc:
                raise self._error(name, f'DO {drive_object}: the drive answered {data.hex(" ")}: {exc}') from None
            low, high = _RANGES[spec.kind]
            return ParameterValue(name.label, _text(value), float(value), spec.unit, low, high,
                                  'ro' if spec.letter == 'r' else 'rw', spec.letter == 'p',
                                  f'DO {drive_object}: {spec.text}')
        kind = _UNSIGNED_BY_SIZE.get(len(data))
        if kind is None:
            return ParameterValue(name.label, data.hex(' '), None, '', None, None,
                                  'ro' if name.letter == 'r' else 'rw', name.letter == 'p',
                                  f'DO {drive_object}: not in the family table; {len(data)} bytes')
        value = decode(kind, data)
        note = f'DO {drive_object}: not in the family table; shown as {kind.upper()}'
        if len(data) == 4:
            note += f' (as REAL32: {decode("f32", data):.6g})'
        return ParameterValue(name.label, _text(value), float(value), '', None, None,
                              'ro' if name.letter == 'r' else 'rw', name.letter == 'p', note)
