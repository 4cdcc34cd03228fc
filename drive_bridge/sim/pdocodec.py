"""How a simulated PDO's mapping becomes bytes and back (CiA 301 PDO mapping): each PDO is
compiled into one ``struct.Struct`` plus a tuple of value getters, since canopen's
``PdoVariable.raw`` is slow; 24-bit entries (INTEGER24 / UNSIGNED24, e.g. the SERVOSTAR's
0x2070:01/02) are three little-endian bytes; values a reader gives out of range are coerced."""
from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from canopen.objectdictionary import ODVariable, datatypes as dt

from drive_bridge.sim.store import ObjectStore, key
from drive_bridge.sim.timers import TimerHandle

RPDO_COMM, RPDO_MAP, TPDO_COMM, TPDO_MAP = 0x1400, 0x1600, 0x1800, 0x1A00
COB_INVALID = 1 << 31

_FORMATS: dict[int | None, str] = {  # ODVariable.data_type may be None
    dt.BOOLEAN: '?', dt.INTEGER8: 'b', dt.UNSIGNED8: 'B', dt.INTEGER16: 'h', dt.UNSIGNED16: 'H',
    dt.INTEGER32: 'i', dt.UNSIGNED32: 'I', dt.INTEGER64: 'q', dt.UNSIGNED64: 'Q',
    dt.REAL32: 'f', dt.REAL64: 'd',
}
DUMMY_INDICES = range(0x0001, 0x0008)  # data type "dummy" entries
# 24-bit types (packed as 3 bytes) -> signed
_TRIPLETS: dict[int | None, bool] = {dt.INTEGER24: True, dt.UNSIGNED24: False}


def _pack24(get: Callable[[], Any]) -> Callable[[], bytes]:
    """A getter of a 24-bit object as its 3 little-endian bytes (out-of-range values wrap)."""
    def packed() -> bytes:
        return (int(get()) & 0xFFFFFF).to_bytes(3, 'little')
    return packed


def _unpack24(signed: bool) -> Callable[[bytes], int]:
    return lambda raw: int.from_bytes(raw, 'little', signed=signed)


def packable(var: ODVariable) -> bool:
    """Whether a PDO can carry the variable's data type."""
    return var.data_type in _FORMATS or var.data_type in _TRIPLETS


class Pdo:
    """One PDO, compiled from its communication and mapping parameters."""

    def __init__(self, transmit: bool, number: int) -> None:
        self.transmit = transmit
        self.number = number
        self.comm = (TPDO_COMM if transmit else RPDO_COMM) + number - 1
        self.mapping = (TPDO_MAP if transmit else RPDO_MAP) + number - 1
        self.cob_id = 0
        self.valid = False
        self.trans_type = 255
        self.inhibit = 0.0  # s
        self.event_timer = 0.0  # s
        self.sync_start = 0
        self.keys: tuple[int, ...] = ()
        self.struct = struct.Struct('<')
        self.getters: tuple[Callable[[], Any], ...] = ()
        self.unpackers: tuple[Callable[[bytes], int] | None, ...] | None = None  # 24-bit fields only
        # runtime
        self.latched: bytes | None = None
        self.sync_count = 0
        self.sync_started = False
        self.last_data: bytes | None = None
        self.last_time = 0.0
        self.deferred: TimerHandle | None = None
        self.event_handle: TimerHandle | None = None
        self.length_error = False

    @property
    def name(self) -> str:
        return f'{"TPDO" if self.transmit else "RPDO"}{self.number}'

    @property
    def synchronous(self) -> bool:
        return self.trans_type <= 240

    def cancel_timers(self) -> None:
        for handle in (self.deferred, self.event_handle):
            if handle is not None:
                handle.cancel()
        self.deferred = self.event_handle = None


def compile_pdo(pdo: Pdo, store: ObjectStore, value_getter: Callable[[int, ODVariable], Callable[[], Any]]) -> None:
    """Compile ``pdo`` from its parameters in ``store`` and clear its runtime state;
    ``value_getter`` gives how a mapped object is read."""
    values = store.values
    cob = values[key(pdo.comm, 1)]
    pdo.cob_id = cob & 0x7FF
    pdo.trans_type = values[key(pdo.comm, 2)]
    pdo.inhibit = values.get(key(pdo.comm, 3), 0) / 10000.0 if pdo.transmit else 0.0
    pdo.event_timer = values.get(key(pdo.comm, 5), 0) / 1000.0 if pdo.transmit else 0.0
    pdo.sync_start = values.get(key(pdo.comm, 6), 0) if pdo.transmit else 0
    fmt, keys, getters = '<', [], []
    unpackers: list[Callable[[bytes], int] | None] = []
    try:
        for sub in range(1, values[key(pdo.mapping, 0)] + 1):
            entry = values[key(pdo.mapping, sub)]
            index, subindex, bits = entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF
            if index in DUMMY_INDICES:
                fmt += 'x' * (bits // 8)
                continue
            k = key(index, subindex)
            var = store.variables[k]
            if bits != len(var):
                raise KeyError(k)
            keys.append(k)
            getter = value_getter(k, var)
            signed = _TRIPLETS.get(var.data_type)
            if signed is None:
                fmt += _FORMATS[var.data_type]
                unpackers.append(None)
            else:  # 24 bits: 3 raw bytes, converted on the way in and out
                fmt += '3s'
                getter = _pack24(getter)
                unpackers.append(_unpack24(signed))
            getters.append(getter)
    except KeyError:  # a mapping the EDS itself got wrong: the PDO cannot exist
        fmt, keys, getters, unpackers = '<', [], [], []
        cob |= COB_INVALID
    pdo.struct = struct.Struct(fmt)
    pdo.keys, pdo.getters = tuple(keys), tuple(getters)
    pdo.unpackers = tuple(unpackers) if any(u is not None for u in unpackers) else None
    pdo.valid = not cob & COB_INVALID and pdo.struct.size > 0
    pdo.latched = None
    pdo.sync_count = 0
    pdo.sync_started = False
    pdo.last_data = None
    pdo.cancel_timers()


def pack(pdo: Pdo, store: ObjectStore) -> bytes:
    """The PDO's data now, as its getters read it."""
    try:
        return pdo.struct.pack(*[get() for get in pdo.getters])
    except struct.error:  # a reader produced a float or an out-of-range int: coerce
        out = []
        for get, k in zip(pdo.getters, pdo.keys):
            var = store.variables[k]
            value = get()
            if isinstance(value, bytes):  # a 24-bit field, already packed
                out.append(value)
                continue
            if var.data_type in dt.INTEGER_TYPES:
                bits = len(var)
                value = int(value) & ((1 << bits) - 1)
                if var.data_type in dt.SIGNED_TYPES and value >= 1 << (bits - 1):
                    value -= 1 << bits
            out.append(value)
        return pdo.struct.pack(*out)


def decode(pdo: Pdo, data: bytes | bytearray) -> list[tuple[int, Any]]:
    """The (object key, value) pairs a received PDO's data carries."""
    values = pdo.struct.unpack_from(data)
    if pdo.unpackers is not None:
        values = tuple(v if u is None else u(v) for v, u in zip(values, pdo.unpackers))
    return list(zip(pdo.keys, values))
