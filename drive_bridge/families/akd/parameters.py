"""Kollmorgen AKD parameters by their ASCII names (``DRV.ACC``, ``FBUS.PARAM04``, ...), over the
drive's ASCII channel, object 0x2026 (shared/drives/akd.md §9.11, the 0x2026 row of §2.9, §1.6,
§8.3; manual §6.2.2.3 and §7.2.1.9).

The channel, as the manual shows it:

- the command is written to 0x2026:1 (VisibleString, write-only) four characters at a time,
  each an expedited download, and ends with "\\r\\n": ``DRV.`` ``FAUL`` ``TS\\r\\n``;
- the reply is read from 0x2026:2 (VisibleString, read-only) four characters at a time:
  ``>No `` ``faul`` ``ts a`` ``ctiv`` ``e\\n\\r\\n``. So a reply is the prompt character ``>``,
  the output lines (each ending "\\n") and "\\r\\n", the same terminator as a command's: a
  reply ends when the characters read so far end with "\\r\\n" (a line inside the output
  ends with "\\n" alone). Reading stops with a named error after :data:`MAX_REPLY`
  characters without it. A chunk the drive answers with nothing (an empty or all-NUL
  chunk, or the SDO abort 0x08000024 "no data available") is asked for again until
  :data:`REPLY_TIMEOUT`.

Reading ``NAME`` sends ``NAME\\r\\n`` and parses the first output line: a number, optionally
followed by the unit in brackets as the AKD terminal prints it (``1000.000 [rpm/s]``), or
else text. Writing sends ``NAME value\\r\\n`` after the checks below, then reads the value
back. A reply whose output starts with ``Error`` is the drive refusing: a ParameterError
carrying the drive's text. Saving sends ``DRV.NVSAVE`` (the same as 0x1010:1 = "save").

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

Unknown names: the channel itself passes any ASCII command to the drive (§6.2.2.3: "an ASCII
communication channel to the drive"), including commands that act (enable, move, ...).
:class:`AkdParameters` refuses names outside the table, with the closest known names
suggested, so a typo never reaches the drive; ``allow_unlisted=True`` passes them through
unchecked (for the AKD's many parameters the CANopen manual does not list).

Known limits: one outstanding transaction per node (a lock per node id and name); a chunk
whose SDO fails leaves the drive with a partial command, so the next transaction first sends
"~\\r\\n", which turns any partial command into an invalid one the drive refuses (its reply
is discarded). Lost SDO responses must not be retried by the port (a repeated chunk would
change the command or drop part of the reply).
"""
from __future__ import annotations

import difflib
import re
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from pathlib import Path

from drive_bridge.families.errors import ParameterError
from drive_bridge.families.parameters import (
    ParameterAccess,
    ParameterPort,
    ParameterValue,
    format_limit,
    parameter_error,
)
from drive_bridge.resources import family_data

ASCII_CHANNEL = 0x2026
COMMAND_SUB = 1
RESPONSE_SUB = 2
CHUNK = 4  # characters per SDO
TERMINATOR = '\r\n'
PROMPT = '>'
MAX_REPLY = 1024  # characters
REPLY_TIMEOUT = 1.0  # s waiting for the drive to have reply characters
ABORT_NO_DATA = 0x08000024
FLUSH = '~'  # makes a partial command left by a failed transaction invalid
SAVE_COMMAND = 'DRV.NVSAVE'
# commands that store or reload the parameters (0x1010 / 0x1011 do the same, akd.md §9.11)
STORE_COMMANDS = frozenset({SAVE_COMMAND, 'DRV.NVLOAD'})
# the parameters that change the drive's link (node address, bit rate) or its master supervision
SAFETY_PARAMETERS = {'FBUS.PARAM01': 'FBUS.PARAM01, the CAN bit rate',
                     'FBUS.PARAM04': 'FBUS.PARAM04, SYNC supervision (F125 after 3 missing SYNCs)'}

_INT_RANGES = {
    'i8': (-(1 << 7), (1 << 7) - 1), 'i16': (-(1 << 15), (1 << 15) - 1), 'i32': (-(1 << 31), (1 << 31) - 1),
    'u8': (0, (1 << 8) - 1), 'u16': (0, (1 << 16) - 1), 'u32': (0, (1 << 32) - 1), 'u64': (0, (1 << 64) - 1),
}
_UNITS = {'pos': 'position units', 'vel': 'velocity units', 'acc': 'acceleration units'}
_NUMBER = re.compile(r'[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?')
_VALUE = re.compile(r'\s*(' + _NUMBER.pattern + r')\s*(?:\[([^\]]*)\])?\s*')


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
        return self.kind in _INT_RANGES

    @property
    def limits(self) -> tuple[Decimal, Decimal] | None:
        """The range of the parameter's object, in ASCII units (None: not a number, or "var")."""
        if not self.numeric or self.scale < 0:
            return None
        low, high = _INT_RANGES[self.kind]
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
_KINDS = frozenset(_INT_RANGES) | {'text', 'cmd'}
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


AKD_PARAMETERS: dict[str, AkdParameter] = read_parameter_table(_UNITS)


@dataclass
class _Channel:
    """The one ASCII channel of a node: a transaction at a time; ``dirty`` after a broken one."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    dirty: bool = False


_CHANNELS: dict[tuple[int, str], _Channel] = {}
_CHANNELS_GUARD = threading.Lock()


def _channel(port: ParameterPort) -> _Channel:
    with _CHANNELS_GUARD:
        return _CHANNELS.setdefault((port.node_id, port.name), _Channel())


def check_text(text: str) -> str | None:
    """Why ``text`` cannot go into a command (None: it can)."""
    bad = [c for c in text if not ' ' <= c <= '~']
    if bad:
        return f'{text!r} has characters the ASCII channel cannot carry ({", ".join(map(repr, bad[:3]))})'
    return None


def parse_reply(reply: str) -> str:
    """The output of a reply: without the prompt, the terminator and surrounding blank lines."""
    text = reply[:-len(TERMINATOR)] if reply.endswith(TERMINATOR) else reply
    if text.startswith('-->'):
        text = text[3:]
    elif text.startswith(PROMPT):
        text = text[1:]
    lines = [line.rstrip('\r').strip() for line in text.split('\n')]
    return '\n'.join(line for line in lines if line)


class AkdParameters(ParameterAccess):
    """The AKD's ASCII parameters of one node, through its ASCII channel 0x2026."""

    def __init__(self, port: ParameterPort, *, allow_unlisted: bool = False, max_reply: int = MAX_REPLY,
                 reply_timeout: float = REPLY_TIMEOUT) -> None:
        self.port = port
        self.allow_unlisted = allow_unlisted
        self.max_reply = max_reply
        self.reply_timeout = reply_timeout
        self._channel = _channel(port)
        self._units: dict[str, str] = {}  # the unit the drive printed, per parameter

    # -- ParameterAccess ----------------------------------------------------------------------------
    def read(self, name: str, drive_object: int = 0) -> ParameterValue:
        spec = self._spec(name, drive_object)
        if spec.access in ('wo', 'cmd'):
            what = 'a command' if spec.access == 'cmd' else 'write-only'
            how = ' (run it with a write of an empty value)' if spec.access == 'cmd' else ''
            raise self._error(spec.name, f'is {what} and cannot be read{how}')
        return self._value(spec, self._command(spec.name, spec.name))

    def write(self, name: str, value_text: str, drive_object: int = 0) -> ParameterValue:
        spec = self._spec(name, drive_object)
        text = self._checked_value(spec, value_text.strip())
        output = self._command(spec.name, f'{spec.name} {text}' if text else spec.name)
        if spec.access == 'rw' and spec.kind != 'cmd':
            return self.read(spec.name)
        return ParameterValue(spec.name, output or text, self._number(text), self._unit(spec), *self._range(spec),
                              spec.access, spec.save_needed, spec.note)

    def stores(self, name: str) -> bool:
        return name.strip().upper() in STORE_COMMANDS

    def safety(self, name: str) -> str | None:
        return SAFETY_PARAMETERS.get(name.strip().upper())

    def save(self, drive_object: int = 0) -> str:
        self._spec(SAVE_COMMAND, drive_object)
        self._command(SAVE_COMMAND, SAVE_COMMAND)
        return (f'{SAVE_COMMAND}: the parameters of node {self.port.node_id} ({self.port.name}) are stored in '
                'non-volatile memory (a new bit rate FBUS.PARAM01 applies after a 24 V restart)')

    # -- checks -------------------------------------------------------------------------------------
    def _error(self, parameter: str, reason: str, drive_text: str = '') -> ParameterError:
        return parameter_error(self.port, parameter, reason, drive_text)

    def _spec(self, name: str, drive_object: int) -> AkdParameter:
        wanted = name.strip().upper()
        if drive_object != 0:
            raise self._error(wanted, f'an AKD has one drive object: drive_object must be 0, not {drive_object}')
        if not wanted:
            raise self._error('', 'no parameter name given (e.g. DRV.ACC)')
        problem = check_text(wanted)
        if problem is not None or ' ' in wanted:
            raise self._error(wanted, problem or 'a parameter name has no spaces (give the value separately)')
        spec = AKD_PARAMETERS.get(wanted)
        if spec is not None:
            return spec
        if self.allow_unlisted:
            return AkdParameter(wanted, 0, 0, 'text', 0, 'rw', '')
        close = difflib.get_close_matches(wanted, list(AKD_PARAMETERS), n=3, cutoff=0.6)
        hint = (f'did you mean {", ".join(close)}?' if close else
                f'the table has {len(AKD_PARAMETERS)} parameters of the AKD CANopen manual, '
                f'e.g. {", ".join(list(AKD_PARAMETERS)[150:153])}')
        raise self._error(wanted, f'unknown AKD parameter; {hint}')

    def _checked_value(self, spec: AkdParameter, text: str) -> str:
        """The value text to send, after the access, type and range checks."""
        if spec.access == 'ro':
            raise self._error(spec.name, 'is read-only')
        if spec.access == 'cmd' or spec.kind == 'cmd':
            if text:
                raise self._error(spec.name, f'is a command and takes no value (got {text!r})')
            return ''
        problem = check_text(text)
        if problem is not None:
            raise self._error(spec.name, problem)
        if not spec.numeric:
            return text  # unlisted parameter: passed as given
        if not text:
            raise self._error(spec.name, 'no value given')
        try:
            value = Decimal(text) if _NUMBER.fullmatch(text) else None
        except InvalidOperation:
            value = None
        if value is None:
            raise self._error(spec.name, f'{text!r} is not a number')
        # to_integral_value, not % 1: a remainder of 1e300 is beyond the decimal context (DivisionImpossible)
        if spec.scale <= 0 and value != value.to_integral_value():
            raise self._error(spec.name, f'{text} is not an integer')
        if spec.scale > 0 and value * 1000 != (value * 1000).to_integral_value():
            raise self._error(spec.name, f'{text} has more than 3 decimals')
        unit = f' {self._unit(spec)}' if self._unit(spec) else ''
        limits = spec.limits
        if limits is not None and value > limits[1]:
            raise self._error(spec.name, f'{text} is above the maximum {format_limit(float(limits[1]))}{unit}')
        if limits is not None and value < limits[0]:
            raise self._error(spec.name, f'{text} is below the minimum {format_limit(float(limits[0]))}{unit}')
        if spec.choices and value not in spec.choices:
            raise self._error(spec.name, f'{text} is not one of {", ".join(map(str, spec.choices))}')
        return str(int(value)) if value == value.to_integral_value() else format(value.normalize(), 'f')

    # -- values -------------------------------------------------------------------------------------
    def _unit(self, spec: AkdParameter) -> str:
        return self._units.get(spec.name, spec.unit)

    def _range(self, spec: AkdParameter) -> tuple[float | None, float | None]:
        if spec.choices:
            return float(min(spec.choices)), float(max(spec.choices))
        limits = spec.limits
        return (float(limits[0]), float(limits[1])) if limits is not None else (None, None)

    @staticmethod
    def _number(text: str) -> float | None:
        return float(text) if _NUMBER.fullmatch(text) else None

    def _value(self, spec: AkdParameter, output: str) -> ParameterValue:
        first = output.split('\n', 1)[0] if output else ''
        match = _VALUE.fullmatch(first) if '\n' not in output else None
        value = float(match.group(1)) if match else None
        if match and match.group(2):
            self._units[spec.name] = match.group(2).strip()
        value_text = match.group(1) if match else output
        return ParameterValue(spec.name, value_text, value, self._unit(spec), *self._range(spec), spec.access,
                              spec.save_needed, spec.note)

    # -- the channel --------------------------------------------------------------------------------
    def _command(self, parameter: str, command: str) -> str:
        """Send ``command``, return the drive's output; ParameterError for an error reply."""
        channel = self._channel
        with channel.lock:
            if channel.dirty:
                try:
                    self._exchange(parameter, FLUSH)
                except ParameterError:
                    pass
                channel.dirty = False
            try:
                output = parse_reply(self._exchange(parameter, command))
            except ParameterError:
                channel.dirty = True
                raise
        if output.lower().startswith('error'):
            raise self._error(parameter, f'the drive refused {command!r}: {output}', drive_text=output)
        return output

    def _exchange(self, parameter: str, command: str) -> str:
        line = command + TERMINATOR
        for start in range(0, len(line), CHUNK):
            chunk = line[start:start + CHUNK]
            try:
                self.port.sdo_write_raw(ASCII_CHANNEL, COMMAND_SUB, chunk.encode('ascii'))
            except Exception as exc:  # the port's SDO error, whatever its type
                raise self._error(parameter, f'sending {command!r} to the ASCII channel 0x2026:1 failed at '
                                             f'character {start}: {exc}') from exc
        reply = ''
        deadline = time.monotonic() + self.reply_timeout
        while not reply.endswith(TERMINATOR):
            if len(reply) >= self.max_reply:
                raise self._error(parameter, f'the reply to {command!r} did not end (no "\\r\\n") within '
                                             f'{self.max_reply} characters: {reply[:60]!r}...')
            chunk = self._read_chunk(parameter, command)
            if chunk:
                reply += chunk
                continue
            if time.monotonic() > deadline:
                got = f' after {reply!r}' if reply else ''
                raise self._error(parameter, f'no reply to {command!r} from the ASCII channel 0x2026:2 within '
                                             f'{self.reply_timeout:g} s{got}')
            time.sleep(0.002)
        return reply

    def _read_chunk(self, parameter: str, command: str) -> str:
        try:
            data = self.port.sdo_read_raw(ASCII_CHANNEL, RESPONSE_SUB)
        except Exception as exc:
            if getattr(exc, 'abort_code', None) == ABORT_NO_DATA:
                return ''
            raise self._error(parameter, f'reading the reply to {command!r} from the ASCII channel 0x2026:2 '
                                         f'failed: {exc}') from exc
        return data.replace(b'\x00', b'').decode('ascii', errors='replace')
