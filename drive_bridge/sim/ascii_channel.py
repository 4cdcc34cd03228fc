"""The simulated AKD's ASCII channel, object 0x2026 (shared/drives/akd.md §9.11 and the 0x2026
row of §2.9; manual §6.2.2.3, §7.2.1.9), with the ASCII parameters behind it.

What the drive does, as the manual shows it and as modelled here:

- 0x2026:0 = 2; 0x2026:1 "Command", VisibleString, write-only: each expedited download
  carries up to 4 characters, appended to a command buffer (a longer download is refused
  with 0x06070012); when the buffer holds "\\r\\n" the command before it is executed;
  0x2026:2 "Response", VisibleString, read-only: each upload returns the next (up to) 4
  characters of the reply; with no reply characters left it aborts 0x08000024 ("no data
  available"; canopen's server for an empty value).
- A reply is ``>``, the output lines each ending "\\n", then "\\r\\n": the manual's
  ``>No faults active\\n\\r\\n`` for DRV.FAULTS. A command without output (a write) gets
  ``>\\r\\n``. A new command discards what is left of the previous reply.
- ``NAME`` reads a parameter: an integer, or a number with 3 decimals for scaled
  parameters, followed by its unit in brackets when it has one (``104857600.000
  [counts/s^2]``); ``NAME value`` writes it; ``DRV.NVSAVE``, ``HOME.SET``, ``DRV.STOP`` are
  commands. Names are case-insensitive.
- Errors are answered as text (the manual prints none; these are the simulator's):
  ``Error: Unknown command``, ``Error: Parameter is read-only``, ``Error: Parameter is
  write-only``, ``Error: Invalid argument``, ``Error: Argument above maximum (...)`` /
  ``below minimum (...)``, ``Error: Invalid value (allowed: ...)``, ``Error: Command too
  long``, and for the control commands (DRV.STOP, HOME.SET, MOTOR.BRAKERLS) while the
  fieldbus controls the drive (FBUS.REMOTE = 1): ``Error: Drive is controlled by the
  fieldbus (FBUS.REMOTE = 1)`` [4.1: "no control command over another channel"].

The parameters: every ASCII parameter of akd.md §8.3 and §1.6, read from the shipped table
(families/akd/data/akd_ascii_parameters.txt, the manual's facts, which the bridge reads too, as
both read akd.eds); the simulator's own model is here: the unit names it prints (its user
units are counts), the power-on values (:data:`SIM_VALUES`), the error texts, what FBUS.REMOTE
and DRV.FAULTS do. Each parameter is its CANopen object, so SDO and ASCII see one
value (SDO = ASCII value x 1000 for "1000:1" parameters). Objects the EDS lacks are added to
the simulated dictionary (their value is stored; nothing in the model acts on them), so
power-on and NMT reset node discard unsaved values and DRV.NVSAVE (= 0x1010:1 "save") makes
the present values the power-on values [10.14]. The 64-bit DINx.PARAM / DOUTx.PARAM are
split over their low and high 32-bit sub-indices. Ranges are the objects' data types (scaled),
plus the documented choices of FBUS.PARAM01 (bit rates, §1.2) and the on/off switches.
FBUS.REMOTE reads and sets the simulated drive's ``remote`` (statusword bit 9); DRV.FAULTS
lists the active EMCY codes.
The command buffer and an unread reply survive an NMT reset (the manual does not say).

Install on a simulated slave with ``AsciiChannel(slave).install()``.
"""
from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from typing import Any

from canopen.objectdictionary import ODVariable, datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.families.akd.parameter_table import AkdParameter, read_parameter_table
from drive_bridge.sim.store import ObjectStore, key

ASCII_CHANNEL = 0x2026
COMMAND, RESPONSE = 1, 2
CHUNK = 4
TERMINATOR = '\r\n'
MAX_COMMAND = 128  # characters in the command buffer without "\r\n"
ABORT_TOO_LONG = 0x06070012  # data type does not match, length of service parameter too high

_TYPES = {'i8': dt.INTEGER8, 'i16': dt.INTEGER16, 'i32': dt.INTEGER32, 'u8': dt.UNSIGNED8,
          'u16': dt.UNSIGNED16, 'u32': dt.UNSIGNED32, 'u64': dt.UNSIGNED64}
_RANGES = {'i8': (-(1 << 7), (1 << 7) - 1), 'i16': (-(1 << 15), (1 << 15) - 1), 'i32': (-(1 << 31), (1 << 31) - 1),
           'u8': (0, 255), 'u16': (0, (1 << 16) - 1), 'u32': (0, (1 << 32) - 1), 'u64': (0, (1 << 64) - 1)}
_CONTROL_COMMANDS = frozenset({'DRV.STOP', 'HOME.SET', 'MOTOR.BRAKERLS'})
_NUMBER = re.compile(r'[-+]?(?:\d+(?:\.\d*)?|\.\d+)')

# the simulated drive's user units (UNIT.PIN = UNIT.POUT = 1): counts, as it prints them
_UNITS = {'pos': 'counts', 'vel': 'counts/s', 'acc': 'counts/s^2'}

# power-on values of the parameters the EDS does not hold (simulation values, not the manual's)
SIM_VALUES: dict[str, float] = {
    'MOTOR.ICONT': 3.0, 'MOTOR.IPEAK': 9.0, 'MOTOR.KT': 0.7, 'MOTOR.POLES': 6, 'MOTOR.VMAX': 6000,
    'MOTOR.R': 2.4, 'MOTOR.INERTIA': 0.5, 'MOTOR.VOLTMAX': 400, 'MOTOR.TEMPFAULT': 140, 'MOTOR.TEMPWARN': 120,
    'MOTOR.TEMP': 30, 'DRV.TEMPERATURES': 35, 'VBUS.VALUE': 320, 'VBUS.UVFTHRESH': 90.0,
    'DRV.ICONT': 6, 'DRV.IPEAK': 18, 'IL.LIMITP': 9.0, 'IL.LIMITN': -9.0, 'IL.KP': 50.0, 'PL.KP': 50.0,
    'VL.KP': 0.05, 'VL.KI': 10.0, 'VL.LIMITP': 100 * 2 ** 20, 'VL.LIMITN': -100 * 2 ** 20,
    'VL.THRESH': 110 * 2 ** 20, 'PL.ERRFTHRESH': 2 ** 20, 'HOME.ACC': 10 * 2 ** 20, 'HOME.DEC': 10 * 2 ** 20,
    'UNIT.PIN': 1, 'UNIT.POUT': 1, 'UNIT.PROTARY': 3, 'UNIT.VROTARY': 3, 'UNIT.ACCROTARY': 3,
    'DRV.OPMODE': 2, 'FB1.ENCRES': 2 ** 20, 'FBUS.PLLTHRESH': 1000, 'WS.NUMLOOPS': 1,
}


@dataclass(frozen=True)
class SimParameter:
    name: str
    keys: tuple[int, ...]  # store keys of its object (two: a 64-bit value over low/high U32); () computed
    kind: str  # i8 .. u64, 'text', 'cmd'
    scale: int  # 0 none, 1 "1:1", 1000 "1000:1", -1 "var"
    access: str  # rw, ro, wo, cmd
    unit: str
    choices: tuple[int, ...] = ()


def _parameter(row: AkdParameter) -> SimParameter:
    """A row of the shipped table as the simulated drive holds it."""
    index, sub = row.index, row.subindex
    keys: tuple[int, ...] = ()
    if index and row.kind == 'u64' and index in (0x3474, 0x3475):  # low / high 32 bits
        keys = (key(index, sub), key(index, sub + (7 if index == 0x3474 else 2)))
    elif index and row.kind != 'cmd':
        keys = (key(index, sub),)
    return SimParameter(row.name, keys, row.kind, row.scale, row.access, row.unit, row.choices)


def _parameters() -> dict[str, SimParameter]:
    return {name: _parameter(row) for name, row in read_parameter_table(_UNITS).items()}


PARAMETERS: dict[str, SimParameter] = _parameters()


def _variable(name: str, index: int, subindex: int, data_type: int, access: str, default: Any) -> ODVariable:
    var = ODVariable(name, index, subindex)
    var.data_type = data_type
    var.access_type = access
    var.default = default
    return var


def _ensure(store: ObjectStore, var: ODVariable) -> None:
    """Add an object the EDS lacks (the EDS's own wins)."""
    k = key(var.index, var.subindex)
    if k in store:
        return
    if not any(store.keys_between(var.index, var.index)):
        if var.subindex == 0:
            store.add(var)
            return
        count = _variable('Highest sub-index supported', var.index, 0, dt.UNSIGNED8, 'ro', 0)
        store.add(count)
    # a further sub-index of a record (ObjectStore.add takes plain variables only)
    store.variables[k] = var
    store.defaults[k] = store.values[k] = var.default
    count_key = key(var.index, 0)
    if count_key in store and store.variables[count_key].access_type == 'ro':
        store.defaults[count_key] = store.values[count_key] = max(store.defaults[count_key], var.subindex)


class AsciiChannel:
    """0x2026 of a simulated AKD; see the module docstring. ``save`` (default: every object's
    present value becomes its power-on value) is what DRV.NVSAVE does."""

    def __init__(self, slave: Any, save: Callable[[], None] | None = None) -> None:
        self.slave = slave
        self.store: ObjectStore = slave.store
        self._save = save
        self._buffer = ''
        self._reply = ''
        self.commands: list[str] = []  # every command executed (for tests)

    def install(self) -> AsciiChannel:
        store = self.store
        _ensure(store, _variable('ASCII channel: command', ASCII_CHANNEL, COMMAND, dt.VISIBLE_STRING, 'wo', ''))
        _ensure(store, _variable('ASCII channel: response', ASCII_CHANNEL, RESPONSE, dt.VISIBLE_STRING, 'ro', ''))
        for parameter in PARAMETERS.values():
            self._add_object(parameter)
        self.slave.register_object(ASCII_CHANNEL, COMMAND, validator=self._check_chunk, on_write=self._on_chunk)
        self.slave.register_object(ASCII_CHANNEL, RESPONSE, reader=self._next_chunk)
        return self

    def _add_object(self, parameter: SimParameter) -> None:
        if not parameter.keys:
            return
        power_on = SIM_VALUES.get(parameter.name, 0)
        raw = int(round(Decimal(str(power_on)) * max(1, parameter.scale)))
        access = {'rw': 'rw', 'ro': 'ro', 'wo': 'wo'}[parameter.access]
        if len(parameter.keys) == 2:  # 64-bit over two UNSIGNED32
            for k, part in zip(parameter.keys, (raw & 0xFFFFFFFF, raw >> 32)):
                _ensure(self.store, _variable(parameter.name, k >> 8, k & 0xFF, dt.UNSIGNED32, access, part))
            return
        k = parameter.keys[0]
        _ensure(self.store, _variable(parameter.name, k >> 8, k & 0xFF, _TYPES[parameter.kind], access, raw))

    # -- SDO side (called with the slave's lock held) ---------------------------------------------------
    def _check_chunk(self, value: Any) -> None:
        if not isinstance(value, str) or len(value) > CHUNK:
            raise SdoAbortedError(ABORT_TOO_LONG)

    def _on_chunk(self, value: str) -> None:
        if not self._buffer:
            self._reply = ''  # a new command: what is left of the last reply is gone
        self._buffer += value
        while TERMINATOR in self._buffer:
            command, self._buffer = self._buffer.split(TERMINATOR, 1)
            self._reply = self._respond(self.execute(command))
        if len(self._buffer) > MAX_COMMAND:
            self._buffer = ''
            self._reply = self._respond('Error: Command too long')

    def _next_chunk(self) -> str:
        chunk, self._reply = self._reply[:CHUNK], self._reply[CHUNK:]
        return chunk

    @staticmethod
    def _respond(output: str) -> str:
        return '>' + (output + '\n' if output else '') + TERMINATOR

    # -- the drive's command interpreter ---------------------------------------------------------------
    def execute(self, command: str) -> str:
        """The output of one command line (without prompt and terminator)."""
        text = command.strip()
        self.commands.append(text)
        if not text:
            return ''
        name, _, argument = text.partition(' ')
        name, argument = name.upper(), argument.strip()
        parameter = PARAMETERS.get(name)
        if parameter is None:
            return 'Error: Unknown command'
        if name in _CONTROL_COMMANDS and getattr(self.slave, 'remote', False):
            return 'Error: Drive is controlled by the fieldbus (FBUS.REMOTE = 1)'
        if parameter.kind == 'cmd':
            return 'Error: Command takes no argument' if argument else self._run(name)
        if not argument:
            if parameter.access == 'wo':
                return 'Error: Parameter is write-only'
            return self._show(parameter)
        if parameter.access == 'ro':
            return 'Error: Parameter is read-only'
        return self._set(parameter, argument)

    def _run(self, name: str) -> str:
        if name == 'DRV.NVSAVE':
            if self._save is not None:
                self._save()
            else:
                for k in self.store.variables:
                    self.store.defaults[k] = self.store.values[k]
        return ''

    def _raw(self, parameter: SimParameter) -> int:
        values = [int(self.store.get(k)) for k in parameter.keys]
        return values[0] | values[1] << 32 if len(values) == 2 else values[0]

    def _show(self, parameter: SimParameter) -> str:
        if parameter.name == 'DRV.FAULTS':
            codes = list(self.slave.emcy.active_codes)
            return '\n'.join(f'Fault: EMCY 0x{code:04X}' for code in codes) if codes else 'No faults active'
        if parameter.name == 'FBUS.REMOTE':
            return str(int(bool(getattr(self.slave, 'remote', True))))
        raw = self._raw(parameter)
        text = f'{Decimal(raw) / parameter.scale:.3f}' if parameter.scale > 0 else str(raw)
        return f'{text} [{parameter.unit}]' if parameter.unit else text

    def _set(self, parameter: SimParameter, argument: str) -> str:
        try:
            value = Decimal(argument) if _NUMBER.fullmatch(argument) else None
        except InvalidOperation:
            value = None
        if value is None or parameter.kind not in _RANGES:
            return 'Error: Invalid argument'
        raw = int((value * max(1, parameter.scale)).to_integral_value())
        low, high = _RANGES[parameter.kind]
        scale = max(1, parameter.scale)
        if raw > high:
            return f'Error: Argument above maximum ({Decimal(high) / scale})'
        if raw < low:
            return f'Error: Argument below minimum ({Decimal(low) / scale})'
        if parameter.choices and raw not in parameter.choices:
            return f'Error: Invalid value (allowed: {", ".join(map(str, parameter.choices))})'
        if parameter.name == 'FBUS.REMOTE':
            self.slave.set_remote(bool(raw))
            return ''
        if len(parameter.keys) == 2:
            self.store.values[parameter.keys[0]] = raw & 0xFFFFFFFF
            self.store.values[parameter.keys[1]] = raw >> 32
        elif parameter.keys:
            self.store.values[parameter.keys[0]] = raw
        return ''
