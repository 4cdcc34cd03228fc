"""The simulated S120's parameter window [2.10]: the SINAMICS parameters of every drive object
as objects 0x2000 + number, reached through the selector p8630 (drive object, page of indices,
thousands range); what a parameter reads as now, and the checks and effects of a write."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from canopen.objectdictionary import ODVariable
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.s120.axis import S120Axis
from drive_bridge.sim.s120.emcy import Message
from drive_bridge.sim.s120.objects import (
    ABORT_NO_SUBINDEX,
    ABORT_NOT_IN_OD,
    ABORT_STATE,
    ABORT_TOO_HIGH,
    ABORT_TOO_LOW,
    ABORT_VALUE_RANGE,
    CU,
    ERROR_BEHAVIOUR,
    PAGE_SIZE,
    PARAMETER_BASE,
    RANGE_SIZE,
)
from drive_bridge.sim.s120.parameters import DYNAMIC, PARAMETERS, Parameter, ParameterSet
from drive_bridge.sim.store import ObjectStore, key

P8630 = PARAMETER_BASE + 8630  # 0x41B6


class WindowedNode(Protocol):
    """The Control Unit as its parameter window sees it."""

    store: ObjectStore
    cu: ParameterSet

    @property
    def messages(self) -> list[Message]: ...

    @property
    def drive_objects(self) -> tuple[int, ...]: ...

    def axis_of(self, do: int) -> S120Axis | None: ...

    def drive_object(self, do: int) -> int: ...

    def schedule_reboot(self) -> None: ...


class ParameterWindow:
    """The window's objects and the selector p8630 (``selector``: drive object, page, thousands)."""

    def __init__(self, node: WindowedNode) -> None:
        self._node = node
        self.selector = [0, 0, 0]

    def add_objects(self, register: Callable[..., None]) -> None:
        """Add 0x2000 + number for every parameter and ``register(index, sub, **hooks)`` it."""
        for number, parameter in PARAMETERS.items():
            index = PARAMETER_BASE + number
            for sub in range(parameter.size):
                var = ODVariable(f'{parameter.label} {parameter.name}', index, sub)
                var.data_type = parameter.data_type
                var.access_type = 'ro' if parameter.read_only else 'rw'
                self._node.store.add(var)  # (no default: 0 or 0.0 by type)
                self._register(register, index, sub)

    def _register(self, register: Callable[..., None], index: int, sub: int) -> None:
        def read() -> Any:
            do, parameter, position = self._lookup(index, sub)
            return self.parameter(do, parameter.number, position)

        def check(value: Any) -> None:
            self._check(index, sub, value)

        def write(value: Any) -> None:
            self._write(index, sub, value)

        register(index, sub, reader=read, validator=check, on_write=write)

    def _lookup(self, index: int, sub: int) -> tuple[int, Parameter, int]:
        """(drive object, parameter, parameter index) an access of (index, sub) reaches."""
        if index == P8630:
            return 0, PARAMETERS[8630], sub
        do, page, thousands = self.selector
        if do == 0:
            raise SdoAbortedError(ABORT_NOT_IN_OD)  # "no access to virtual objects"
        parameter = PARAMETERS.get(index - PARAMETER_BASE + RANGE_SIZE * thousands)
        if parameter is None or not parameter.on(do == CU) or parameter.scope == 'global':
            raise SdoAbortedError(ABORT_NOT_IN_OD)
        position = sub + PAGE_SIZE * page
        if position >= parameter.size:
            raise SdoAbortedError(ABORT_NO_SUBINDEX)
        return do, parameter, position

    def parameter(self, do: int, number: int, index: int = 0) -> Any:
        """Parameter ``number`` [``index``] of drive object ``do`` (1: the Control Unit) now."""
        node = self._node
        if number == 8630:
            return self.selector[index]
        if number == 8609:
            return node.store.values.get(key(ERROR_BEHAVIOUR, index + 1), 1)
        do = node.drive_object(do)
        if number in (947, 949, 2110):
            fault = number != 2110
            items = [m for m in node.messages if m.do == do and m.fault == fault][:8]
            if index >= len(items):
                return 0
            return items[index].value if number == 949 else items[index].number
        axis = node.axis_of(do)
        if axis is None:
            return node.cu.get(number, index)
        if number in DYNAMIC:
            return axis.dynamic_parameter(number, index)
        return axis.parameter(number, index)

    def _check(self, index: int, sub: int, value: Any) -> None:
        do, parameter, position = self._lookup(index, sub)
        if parameter.number == 8630:
            allowed: tuple[int, ...] | range = ((0, CU, *self._node.drive_objects), range(4), range(6))[position]
            if value not in allowed:
                raise SdoAbortedError(ABORT_VALUE_RANGE)
            return
        if parameter.configuration and self._node.cu.get(9) != 3:
            raise SdoAbortedError(ABORT_STATE)  # only in device configuration (p0009 = 3) [2.10]
        if parameter.choices and value not in parameter.choices:
            raise SdoAbortedError(ABORT_VALUE_RANGE)
        if parameter.high is not None and value > parameter.high:
            raise SdoAbortedError(ABORT_TOO_HIGH)
        if parameter.low is not None and value < parameter.low:
            raise SdoAbortedError(ABORT_TOO_LOW)

    def _write(self, index: int, sub: int, value: Any) -> None:
        node = self._node
        do, parameter, position = self._lookup(index, sub)
        number = parameter.number
        if number == 8630:
            self.selector[position] = int(value)
            return
        if number == 8609:
            node.store.values[key(ERROR_BEHAVIOUR, position + 1)] = int(value)
            return
        axis = node.axis_of(do)
        if axis is not None:
            axis.set_parameter(number, position, value)
            return
        old = node.cu.get(number, position)
        node.cu.set(number, position, value)
        if number == 9 and old != 0 and value == 0:  # the CU reboots by itself [2.10]
            node.schedule_reboot()
