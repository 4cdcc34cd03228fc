"""The SINAMICS parameters the simulated S120 knows, reached through the window 0x2000 +
number on the drive object selected in p8630 [3].

The manual gives no parameter data types [3]: the types below are SINAMICS's own
(FloatingPoint32 for speeds, times and torques, as in the S120 List Manual) [B]. ``scope``:
'cu' only on the Control Unit, 'motor' only on a motor drive object, 'all' on both,
'global' (p8630) one value for the whole node, reachable whatever is selected.
"""
from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from canopen.objectdictionary import datatypes as dt

U8, U16, U32, I16, I32, REAL = (dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32, dt.INTEGER16, dt.INTEGER32,
                                dt.REAL32)


@dataclass(frozen=True)
class Parameter:
    """One SINAMICS parameter (``size`` > 1: indexed, sub-index = parameter index)."""

    number: int
    name: str
    data_type: int
    scope: str  # 'cu', 'motor', 'all', 'global'
    size: int = 1
    read_only: bool = False
    low: float | None = None
    high: float | None = None
    choices: tuple[int, ...] = ()
    unit: str = ''
    boot: bool = False  # takes effect at the next boot of the CU (power-on, p0009 reboot)
    configuration: bool = False  # writable only while p0009 = 3 (device configuration) [2.10]
    profile: bool = False  # mirrored by a CiA 402 object (saved with the application objects too)
    volatile: bool = False  # not saved: its factory value at every boot

    @property
    def label(self) -> str:
        return f'{"r" if self.read_only else "p"}{self.number:04d}'

    def on(self, cu: bool) -> bool:
        """Whether a drive object of this kind (Control Unit or motor) has the parameter."""
        return self.scope in ('all', 'global') or self.scope == ('cu' if cu else 'motor')


def _p(number: int, name: str, data_type: int, scope: str, **kw: Any) -> Parameter:
    return Parameter(number, name, data_type, scope, **kw)


PARAMETERS: dict[int, Parameter] = {p.number: p for p in (
    # Control Unit
    _p(9, 'device commissioning parameter filter', U16, 'cu', choices=(0, 1, 2, 3, 4, 29, 30), volatile=True),
    _p(8609, 'CAN error behaviour (= 0x1029:1/2)', U32, 'cu', size=2, low=0, high=2),
    _p(8620, 'CAN node id (effective after POWER ON)', U8, 'cu', low=1, high=127, boot=True),
    _p(8630, 'virtual object selector: DO, sub-index page, parameter range', U16, 'global', size=3),
    _p(8684, 'NMT state after start-up', U8, 'cu', choices=(4, 5, 127), boot=True),
    _p(8743, 'drive object per axis slot (offset factor = index)', U16, 'cu', size=8, read_only=True),
    _p(8848, 'IF2 PZD sampling time', REAL, 'cu', low=1.0, high=500.0, unit='ms', boot=True,
       configuration=True),
    # motor drive objects
    _p(61, 'speed actual value, encoder', REAL, 'motor', read_only=True, unit='rpm'),
    _p(62, 'speed setpoint (after the ramp-function generator)', REAL, 'motor', read_only=True, unit='rpm'),
    _p(63, 'speed actual value', REAL, 'motor', read_only=True, unit='rpm'),
    _p(79, 'total torque setpoint', REAL, 'motor', read_only=True, unit='Nm'),
    _p(80, 'torque actual value', REAL, 'motor', read_only=True, unit='Nm'),
    _p(311, 'rated motor speed', REAL, 'motor', low=0.0, high=210000.0, unit='rpm'),
    _p(333, 'rated motor torque', REAL, 'motor', read_only=True, unit='Nm'),
    _p(400, 'encoder type selection per encoder data set (0: no encoder, 9999: user-defined)', U32, 'motor',
       size=3, low=0, high=9999, boot=True),
    _p(408, 'encoder pulses per revolution per encoder data set', U32, 'motor', size=3, low=0, high=65535,
       boot=True),
    _p(418, 'encoder fine resolution (bits) per encoder data set', U8, 'motor', size=3, low=2, high=18, boot=True),
    _p(482, 'position actual value Gn_XIST1 (encoder increments) per encoder', U32, 'motor', size=3,
       read_only=True),
    _p(1080, 'minimum speed', REAL, 'motor', low=0.0, high=210000.0, unit='rpm', profile=True),
    _p(1082, 'maximum speed', REAL, 'motor', low=0.0, high=210000.0, unit='rpm', profile=True),
    _p(1120, 'ramp-function generator ramp-up time', REAL, 'motor', low=0.0, high=999999.0, unit='s',
       profile=True),
    _p(1121, 'ramp-function generator ramp-down time', REAL, 'motor', low=0.0, high=999999.0, unit='s',
       profile=True),
    _p(1135, 'OFF3 ramp-down time', REAL, 'motor', low=0.0, high=5400.0, unit='s', profile=True),
    _p(1170, 'speed setpoint (= 0x606B)', REAL, 'motor', read_only=True, unit='rpm'),
    _p(1300, 'open/closed-loop control mode (20/21 speed, 22/23 torque)', I16, 'motor', read_only=True),
    _p(1520, 'torque limit upper', REAL, 'motor', low=0.0, high=1e6, unit='Nm', profile=True),
    _p(8641, 'drive reaction to a CAN communication error (= 0x6007)', I16, 'motor', low=0, high=3,
       profile=True),
    _p(8784, 'CBC status word (= 0x6041)', U16, 'motor', read_only=True),
    _p(8795, 'CBC control word (= 0x6040)', U16, 'motor', read_only=True),
    # every drive object
    _p(947, 'fault number', U16, 'all', size=8, read_only=True),
    _p(949, 'fault value', I32, 'all', size=8, read_only=True),
    _p(2110, 'alarm number', U16, 'all', size=8, read_only=True),
)}

DYNAMIC = frozenset({61, 62, 63, 79, 80, 482, 1170, 1300, 8784, 8795, 947, 949, 2110})  # computed from the model
MIRRORED = frozenset({8609})  # kept in a CANopen object (0x1029) of the store


class ParameterSet:
    """The stored parameter values of one drive object: present (RAM), saved (memory card) and
    factory values, each a list per parameter number (index = parameter index)."""

    def __init__(self, cu: bool, defaults: Mapping[int, Any]) -> None:
        self.cu = cu
        self.factory: dict[int, list[Any]] = {}
        for number, parameter in PARAMETERS.items():
            if not parameter.on(cu) or number in DYNAMIC or number in MIRRORED or parameter.scope == 'global':
                continue
            value = defaults[number]
            self.factory[number] = list(value) if isinstance(value, (list, tuple)) else [value] * parameter.size
        self.saved = copy.deepcopy(self.factory)
        self.values = copy.deepcopy(self.factory)

    def has(self, number: int) -> bool:
        parameter = PARAMETERS.get(number)
        return parameter is not None and parameter.on(self.cu) and parameter.scope != 'global'

    def get(self, number: int, index: int = 0) -> Any:
        return self.values[number][index]

    def set(self, number: int, index: int, value: Any) -> None:
        self.values[number][index] = value

    def save(self, numbers: Iterable[int] | None = None) -> None:
        for number in self.values if numbers is None else numbers:
            if number in self.values:
                self.saved[number] = list(self.values[number])

    def load_saved(self) -> None:
        self.values = copy.deepcopy(self.saved)
        for number in self.values:
            if PARAMETERS[number].volatile:
                self.values[number] = list(self.factory[number])

    def load_factory(self, numbers: Iterable[int] | None = None) -> None:
        for number in self.factory if numbers is None else numbers:
            if number in self.factory:
                self.values[number] = list(self.factory[number])


def profile_parameters() -> frozenset[int]:
    """Parameters a CiA 402 object mirrors (saved by 0x1010:3 / restored by 0x1011:3 as well)."""
    return frozenset(n for n, p in PARAMETERS.items() if p.profile)
