"""The simulated device's object dictionary values, decoded, keyed by one int.

canopen's LocalNode keeps raw bytes and finds objects through the EDS on every
access; the simulator needs typed values on its hot path (PDO packing, model
parameters), so values live here as Python numbers under ``key(index, subindex)``.
Dynamic objects (statusword, actual values) are *readers*: callables asked on every
read, so SDO and TPDO always see the model's present value.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from canopen import ObjectDictionary
from canopen.objectdictionary import ODArray, ODRecord, ODVariable, datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError

ABORT_NOT_IN_OD = 0x06020000
ABORT_NO_SUBINDEX = 0x06090011

Reader = Callable[[], Any]


def key(index: int, subindex: int = 0) -> int:
    """One int for (index, subindex): cheap to hash, sorts like the dictionary."""
    return index << 8 | subindex


def split(k: int) -> tuple[int, int]:
    return k >> 8, k & 0xFF


def _initial(var: ODVariable) -> Any:
    value = var.value if var.value is not None else var.default
    if value is not None:
        return value
    if var.data_type in (dt.VISIBLE_STRING, dt.UNICODE_STRING):
        return ''
    if var.data_type in (dt.OCTET_STRING, dt.DOMAIN):
        return b''
    if var.data_type in dt.FLOAT_TYPES:
        return 0.0
    return 0


class ObjectStore:
    """Typed values of every object of an OD, with power-on defaults and readers."""

    def __init__(self, od: ObjectDictionary) -> None:
        self.od = od
        self.variables: dict[int, ODVariable] = {}
        self._indices: set[int] = set(od)  # objects that exist (the EDS's, plus added, less removed)
        for index in od:
            entry = od[index]
            if isinstance(entry, ODVariable):
                self.variables[key(index, 0)] = entry
            elif isinstance(entry, (ODRecord, ODArray)):
                for sub, var in entry.subindices.items():
                    self.variables[key(index, sub)] = var
        self.defaults: dict[int, Any] = {k: _initial(v) for k, v in self.variables.items()}
        self.values: dict[int, Any] = dict(self.defaults)
        self.readers: dict[int, Reader] = {}

    def __contains__(self, k: int) -> bool:
        return k in self.variables

    def keys_between(self, low: int, high: int) -> Iterator[int]:
        """Keys of the objects with ``low <= index <= high``."""
        lo, hi = key(low, 0), key(high, 0xFF)
        return (k for k in self.variables if lo <= k <= hi)

    def find(self, index: int, subindex: int) -> ODVariable:
        """The variable at (index, subindex), or the CiA 301 abort for a missing one.

        Unlike canopen's LocalNode, array sub-indices beyond the EDS do not exist
        (ODArray invents them on lookup), and a plain variable has only sub-index 0.
        """
        var = self.variables.get(key(index, subindex))
        if var is not None:
            return var
        if index in self._indices:
            raise SdoAbortedError(ABORT_NO_SUBINDEX)
        raise SdoAbortedError(ABORT_NOT_IN_OD)

    def add(self, var: ODVariable) -> None:
        """An entry (``var.index``, ``var.subindex``) the device has although its EDS lacks it.

        An entry the EDS has is kept: the device's own description wins."""
        k = key(var.index, var.subindex)
        if k in self.variables:
            return
        self._indices.add(var.index)
        self.variables[k] = var
        self.defaults[k] = self.values[k] = _initial(var)

    def remove(self, index: int) -> None:
        """An object of the EDS the simulated device does not have (SDO aborts 0x06020000)."""
        self._indices.discard(index)
        for k in list(self.keys_between(index, index)):
            for table in (self.variables, self.defaults, self.values, self.readers):
                table.pop(k, None)

    def get(self, k: int) -> Any:
        reader = self.readers.get(k)
        return reader() if reader is not None else self.values[k]

    def set_default(self, index: int, subindex: int, value: Any) -> None:
        """Change a power-on value (simulation options such as the serial number)."""
        k = key(index, subindex)
        if k not in self.variables:
            raise KeyError(f'0x{index:04X}:{subindex:02X} is not in the object dictionary')
        self.defaults[k] = value
        self.values[k] = value

    def reset(self, low: int = 0x0000, high: int = 0xFFFF) -> None:
        """Back to the power-on values for indices ``low..high`` (in place: getters keep the dict)."""
        for k in list(self.keys_between(low, high)):
            self.values[k] = self.defaults[k]

    @staticmethod
    def encode(var: ODVariable, value: Any) -> bytes:
        if var.data_type in dt.INTEGER_TYPES and var.data_type in var.STRUCT_TYPES:
            # packed directly: canopen would warn on every read of a value outside a file's
            # limits (some files give INTEGER8 limits as 0xFF, read as -1)
            return bytes(var.STRUCT_TYPES[var.data_type].pack(int(value)))
        return var.encode_raw(value)

    @staticmethod
    def decode(var: ODVariable, data: bytes) -> Any:
        return var.decode_raw(bytes(data))
