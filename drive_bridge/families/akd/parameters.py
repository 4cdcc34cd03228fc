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

The table of parameters (:data:`~.parameter_table.AKD_PARAMETERS`, what the bridge makes of a row)
is :mod:`~drive_bridge.families.akd.parameter_table`.

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
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation

from drive_bridge.families.akd.parameter_table import AKD_PARAMETERS, AkdParameter
from drive_bridge.families.errors import ParameterError
from drive_bridge.families.parameters import (
    ParameterAccess,
    ParameterPort,
    ParameterValue,
    format_limit,
    parameter_error,
)

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

_NUMBER = re.compile(r'[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?')
_VALUE = re.compile(r'\s*(' + _NUMBER.pattern + r')\s*(?:\[([^\]]*)\])?\s*')


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
