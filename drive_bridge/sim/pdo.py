"""The PDO engine of a simulated slave: CiA 301 rules for PDO parameters, RPDO
latch/apply, TPDO on SYNC, on change (inhibit time) and by event timer.

canopen's LocalNode only decodes received RPDOs into ``PdoMap.data`` and never sends
a TPDO by itself (ecosystem doc §1.1), and ``PdoVariable.raw`` is slow (§1.3). Each
PDO is therefore compiled into one ``struct.Struct`` plus a tuple of value getters,
recompiled whenever its parameters are written.

Abort codes for parameter writes (CiA 301 §7.5.2.35-38 leave some choices open):

- mapping (sub0 or an entry) written while the PDO is valid, or an entry written
  while sub0 != 0: 0x08000022 (data cannot be transferred because of the device
  state) -- the state the master must change first;
- mapped object missing: 0x06020000; not PDO-mappable, or not readable (TPDO) /
  writable (RPDO), or a dummy entry: 0x06040041; entry length differs from the
  object's size: 0x06040043; more than 64 bits at sub0 = n: 0x06040042; sub0 larger
  than the number of entries: 0x06090031;
- COB-ID bits 0-29 changed while valid, 29-bit id, restricted CAN-ID, reserved or
  RTR-only transmission type (241..253), inhibit time or SYNC start value changed
  while valid, SYNC start value > 240: 0x06090030.

Mapping entries of 24 bits (INTEGER24 / UNSIGNED24, e.g. the SERVOSTAR's 0x2070:01/02) are
packed as three little-endian bytes.

Behaviour choices: an RPDO of type 0..240 is applied at the next SYNC whatever n
(the last one received wins); all RPDOs latched for a SYNC are stored before any
reacts. An RPDO shorter than its mapping is dropped with EMCY 0x8210 (once until a
good one arrives; an event, not a lasting error); a longer one is used. Event-driven
TPDOs (254/255) are sent on entering OPERATIONAL, on change (changes within the
inhibit time coalesce into one frame at its end) and by event timer; RTR-only types
(252/253) are never sent. With a SYNC counter, a TPDO's first transmission waits for
the SYNC start value. A (re)configured TPDO restarts its SYNC count.

The synchronous window (0x1007, µs, 0 = not used; CiA 301 §7.5.2.9) opens at each SYNC: a
synchronous RPDO received after it expired is discarded until the next SYNC (counted in
``rpdo_late``); times are the frames' receive stamps. Before the first SYNC nothing is late.
"""
from __future__ import annotations

import functools
import math
import struct
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

from canopen.objectdictionary import ODVariable, datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.store import ObjectStore, key
from drive_bridge.sim.timers import TimerHandle, TimerThread

RPDO_COMM, RPDO_MAP, TPDO_COMM, TPDO_MAP = 0x1400, 0x1600, 0x1800, 0x1A00
SYNC_WINDOW = 0x1007
PDO_PARAMETERS = (0x1400, 0x1BFF)
COB_INVALID = 1 << 31
COB_NO_RTR = 1 << 30
COB_EXTENDED = 1 << 29
MAX_BITS = 64

ABORT_UNSUPPORTED_ACCESS_STATE = 0x08000022
ABORT_NOT_IN_OD = 0x06020000
ABORT_NOT_MAPPABLE = 0x06040041
ABORT_PDO_TOO_LONG = 0x06040042
ABORT_INCOMPATIBLE = 0x06040043
ABORT_INVALID_VALUE = 0x06090030
ABORT_VALUE_TOO_HIGH = 0x06090031

EMCY_PDO_LENGTH = 0x8210

_FORMATS: dict[int | None, str] = {  # ODVariable.data_type may be None
    dt.BOOLEAN: '?', dt.INTEGER8: 'b', dt.UNSIGNED8: 'B', dt.INTEGER16: 'h', dt.UNSIGNED16: 'H',
    dt.INTEGER32: 'i', dt.UNSIGNED32: 'I', dt.INTEGER64: 'q', dt.UNSIGNED64: 'Q',
    dt.REAL32: 'f', dt.REAL64: 'd',
}
_DUMMY_INDICES = range(0x0001, 0x0008)  # data type "dummy" entries
# 24-bit types (packed as 3 bytes) -> signed
_TRIPLETS: dict[int | None, bool] = {dt.INTEGER24: True, dt.UNSIGNED24: False}


def _pack24(get: Callable[[], Any]) -> Callable[[], bytes]:
    """A getter of a 24-bit object as its 3 little-endian bytes (out-of-range values wrap)."""
    def packed() -> bytes:
        return (int(get()) & 0xFFFFFF).to_bytes(3, 'little')
    return packed


def _unpack24(signed: bool) -> Callable[[bytes], int]:
    return lambda raw: int.from_bytes(raw, 'little', signed=signed)


def restricted_can_id(can_id: int) -> bool:
    """CAN-IDs CiA 301 (table 62) reserves for other services."""
    return (can_id == 0 or 0x001 <= can_id <= 0x07F or 0x101 <= can_id <= 0x180
            or 0x581 <= can_id <= 0x5FF or 0x601 <= can_id <= 0x67F or 0x6E0 <= can_id <= 0x6FF
            or 0x701 <= can_id <= 0x77F or 0x780 <= can_id <= 0x7FF)


def _abort(code: int) -> SdoAbortedError:
    return SdoAbortedError(code)


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


class PdoEngine:
    """All PDOs of one slave. Every method is called with the slave's lock held.

    Hooks a device model's PDO rules override: :meth:`validate` (parameter writes),
    :meth:`mapping_locked`, :meth:`accepted_rpdos`, :meth:`due_rpdos`, :meth:`value_getter`, :meth:`has_changed`,
    :meth:`acyclic_due`.
    """

    def __init__(self, store: ObjectStore, *, lock: threading.RLock, timers: TimerThread,
                 send: Callable[[int, bytes], None], write_many: Callable[[list[tuple[int, Any]]], None],
                 subscribe: Callable[[int, Callable], None], unsubscribe: Callable[[int, Callable], None],
                 rpdo_allowed: Callable[[], bool], tpdo_allowed: Callable[[], bool],
                 emcy: Callable[[int], None]) -> None:
        self._store = store
        self._lock = lock
        self._timers = timers
        self._send = send
        self._write_many = write_many
        self._subscribe = subscribe
        self._unsubscribe = unsubscribe
        self._rpdo_allowed = rpdo_allowed
        self._tpdo_allowed = tpdo_allowed
        self._emcy = emcy
        self.rpdos: dict[int, Pdo] = {}
        self.tpdos: dict[int, Pdo] = {}
        self._by_index: dict[int, Pdo] = {}
        for transmit, comm_base, table in ((False, RPDO_COMM, self.rpdos), (True, TPDO_COMM, self.tpdos)):
            for number in range(1, 513):
                comm = comm_base + number - 1
                if key(comm, 1) in store and key(comm + 0x200, 0) in store:
                    pdo = Pdo(transmit, number)
                    table[number] = pdo
                    self._by_index[pdo.comm] = self._by_index[pdo.mapping] = pdo
        self._rx_by_cob: dict[int, Pdo] = {}
        self._event_tpdos: tuple[Pdo, ...] = ()
        self._sync_tpdos: tuple[Pdo, ...] = ()
        self.rpdo_received = 0
        self.rpdo_late = 0  # synchronous RPDOs discarded: received after the synchronous window
        self.tpdo_sent = 0
        self._window_end = math.inf  # receive stamp after which synchronous RPDOs are discarded

    # ---- configuration -------------------------------------------------------------
    def rebuild(self) -> None:
        """Compile every PDO from the store (after a reset) and subscribe the RPDOs."""
        self._window_end = math.inf  # 0x1007 back to its default: no window until the next SYNC
        for pdo in self._by_index.values():
            self._compile(pdo)
        self._refresh()

    def close(self) -> None:
        for cob in list(self._rx_by_cob):
            self._unsubscribe(cob, self.on_rpdo)
        self._rx_by_cob.clear()
        for pdo in self._by_index.values():
            pdo.cancel_timers()

    def handles(self, index: int) -> bool:
        return index in self._by_index

    def validate(self, index: int, subindex: int, value: int) -> None:
        """Raise the CiA 301 abort for a write the device must refuse."""
        pdo = self._by_index[index]
        values = self._store.values
        cob = values[key(pdo.comm, 1)]
        valid = self.mapping_locked(pdo, cob)
        if index == pdo.comm:
            if subindex == 1:
                if value & COB_EXTENDED:
                    raise _abort(ABORT_INVALID_VALUE)
                new_valid = not value & COB_INVALID
                if valid and new_valid and (value & 0x1FFFFFFF) != (cob & 0x1FFFFFFF):
                    raise _abort(ABORT_INVALID_VALUE)
                if new_valid and restricted_can_id(value & 0x7FF):
                    raise _abort(ABORT_INVALID_VALUE)
            elif subindex == 2:
                if 241 <= value <= 253:
                    raise _abort(ABORT_INVALID_VALUE)
            elif subindex == 3 and pdo.transmit:
                if valid and value != values[key(pdo.comm, 3)]:
                    raise _abort(ABORT_INVALID_VALUE)
            elif subindex == 6 and pdo.transmit and (value > 240 or (valid and value != values[key(pdo.comm, 6)])):
                raise _abort(ABORT_INVALID_VALUE)
            return
        # mapping parameter
        if valid:
            raise _abort(ABORT_UNSUPPORTED_ACCESS_STATE)
        if subindex == 0:
            entries = sorted(s for k in self._store.keys_between(index, index) if (s := k & 0xFF) > 0)
            if value > len(entries):
                raise _abort(ABORT_VALUE_TOO_HIGH)
            bits = 0
            for sub in range(1, value + 1):
                entry = values[key(index, sub)]
                if entry == 0:
                    raise _abort(ABORT_NOT_IN_OD)
                self._check_entry(pdo, entry)
                bits += entry & 0xFF
            if bits > MAX_BITS:
                raise _abort(ABORT_PDO_TOO_LONG)
            return
        if values[key(index, 0)] != 0:
            raise _abort(ABORT_UNSUPPORTED_ACCESS_STATE)
        if value != 0:
            self._check_entry(pdo, value)

    def accepted_rpdos(self, valid: list[Pdo]) -> list[Pdo]:
        """Hook: of the valid RPDOs (in number order), those the device receives. Default: all
        (a device with a hardware limit on receive PDOs serves only some)."""
        return valid

    def mapping_locked(self, pdo: Pdo, cob: int) -> bool:
        """Hook: whether the PDO's COB-ID, mapping, inhibit time and SYNC start value are locked
        against changes (CiA 301: while the PDO is valid, ``cob`` its 0x14xx/0x18xx:1). A PDO
        whose EDS makes the COB-ID read-only cannot be made invalid: its mapping stays open."""
        var = self._store.variables.get(key(pdo.comm, 1))
        return not cob & COB_INVALID and var is not None and var.writable

    def check_entry(self, pdo: Pdo, entry: int) -> ODVariable:
        """The mapped variable of mapping ``entry`` for ``pdo``, or the CiA 301 abort (for device
        models with their own mapping write rules)."""
        return self._check_entry(pdo, entry)

    def _check_entry(self, pdo: Pdo, entry: int) -> ODVariable:
        index, sub, bits = entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF
        if index in _DUMMY_INDICES:
            raise _abort(ABORT_NOT_MAPPABLE)  # the EDS declares no dummy usage
        var = self._store.variables.get(key(index, sub))
        if var is None:
            raise _abort(ABORT_NOT_IN_OD)
        usable = var.readable if pdo.transmit else var.writable
        if not var.pdo_mappable or not usable or (var.data_type not in _FORMATS
                                                  and var.data_type not in _TRIPLETS):
            raise _abort(ABORT_NOT_MAPPABLE)
        if bits != len(var):
            raise _abort(ABORT_INCOMPATIBLE)
        return var

    def written(self, index: int) -> None:
        """A parameter of this PDO changed: recompile it."""
        pdo = self._by_index[index]
        self._compile(pdo)
        self._refresh()
        if pdo.transmit and pdo.valid and pdo.trans_type >= 254 and self._tpdo_allowed():
            self._send_event(pdo, time.monotonic(), force=True)

    def _compile(self, pdo: Pdo) -> None:
        values = self._store.values
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
                if index in _DUMMY_INDICES:
                    fmt += 'x' * (bits // 8)
                    continue
                k = key(index, subindex)
                var = self._store.variables[k]
                if bits != len(var):
                    raise KeyError(k)
                keys.append(k)
                getter = self.value_getter(k, var)
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

    def value_getter(self, k: int, var: ODVariable) -> Callable[[], Any]:
        """Hook: how a TPDO reads mapped object ``k`` (default: as SDO reads it)."""
        reader = self._store.readers.get(k)
        if reader is not None:
            return reader
        return functools.partial(self._store.values.__getitem__, k)

    def _refresh(self) -> None:
        wanted = {p.cob_id: p for p in self.accepted_rpdos([p for p in self.rpdos.values() if p.valid])}
        for cob in set(self._rx_by_cob) - set(wanted):
            self._unsubscribe(cob, self.on_rpdo)
        for cob in set(wanted) - set(self._rx_by_cob):
            self._subscribe(cob, self.on_rpdo)
        self._rx_by_cob = wanted
        # 252/253 (RTR only) are never sent: RTR frames do not reach canopen's subscribers
        self._event_tpdos = tuple(p for p in self.tpdos.values() if p.valid and p.trans_type >= 254)
        self._sync_tpdos = tuple(p for p in self.tpdos.values() if p.valid and p.synchronous)

    # ---- NMT -------------------------------------------------------------------------
    def enter_operational(self) -> None:
        now = time.monotonic()
        for pdo in self.tpdos.values():
            pdo.sync_count, pdo.sync_started, pdo.last_data = 0, False, None
        for pdo in self._event_tpdos:
            self._send_event(pdo, now, force=True)

    def leave_operational(self) -> None:
        for pdo in self._by_index.values():
            pdo.latched = None
            pdo.cancel_timers()

    # ---- RPDO ------------------------------------------------------------------------
    def on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        """Notifier thread: latch a synchronous RPDO, apply an event-driven one now."""
        with self._lock:
            if not self._rpdo_allowed():
                return
            pdo = self._rx_by_cob.get(can_id)
            if pdo is None:
                return
            if len(data) < pdo.struct.size:
                if not pdo.length_error:  # CiA 301: PDO not processed due to length error
                    pdo.length_error = True
                    self._emcy(EMCY_PDO_LENGTH)
                return
            pdo.length_error = False
            self.rpdo_received += 1
            if pdo.synchronous:
                if timestamp > self._window_end:
                    self.rpdo_late += 1
                    return
                pdo.latched = bytes(data)
            else:
                self._write_many(self._decode(pdo, data))
                self.poll_events()

    def open_window(self, timestamp: float) -> None:
        """At SYNC (received at ``timestamp``): the synchronous window of 0x1007 starts."""
        window = self._store.values.get(key(SYNC_WINDOW, 0), 0)
        self._window_end = timestamp + window * 1e-6 if window else math.inf

    def apply_latched(self) -> None:
        """At SYNC: the latched data of the RPDOs due, all stored before any reacts."""
        items: list[tuple[int, Any]] = []
        for pdo in self.due_rpdos():
            if pdo.latched is not None:
                items += self._decode(pdo, pdo.latched)
                pdo.latched = None
        if items:
            self._write_many(items)

    def due_rpdos(self) -> Iterable[Pdo]:
        """Hook: at SYNC, the RPDOs whose latched data apply now, in the order they are stored.
        Default: every RPDO (types 0..240 alike: at the next SYNC)."""
        return self._rx_by_cob.values()

    @staticmethod
    def _decode(pdo: Pdo, data: bytes | bytearray) -> list[tuple[int, Any]]:
        values = pdo.struct.unpack_from(data)
        if pdo.unpackers is not None:
            values = tuple(v if u is None else u(v) for v, u in zip(values, pdo.unpackers))
        return list(zip(pdo.keys, values))

    # ---- TPDO ------------------------------------------------------------------------
    def _pack(self, pdo: Pdo) -> bytes:
        try:
            return pdo.struct.pack(*[get() for get in pdo.getters])
        except struct.error:  # a reader produced a float or an out-of-range int: coerce
            out = []
            for get, k in zip(pdo.getters, pdo.keys):
                var = self._store.variables[k]
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

    def transmit_on_sync(self, counter: int | None) -> None:
        """Right after SYNC (model already stepped): the synchronous TPDOs that are due."""
        if not self._sync_tpdos or not self._tpdo_allowed():
            return
        now = time.monotonic()
        for pdo in self._sync_tpdos:
            if pdo.trans_type == 0:  # acyclic synchronous: on SYNC, when changed
                data = self._pack(pdo)
                if self.acyclic_due(pdo, data):
                    self._emit(pdo, data, now)
                continue
            if not pdo.sync_started:
                if counter is not None and pdo.sync_start and counter != pdo.sync_start:
                    continue
                pdo.sync_started = True
                if counter is not None and pdo.sync_start:
                    pdo.sync_count = pdo.trans_type - 1  # first transmission at this SYNC
            pdo.sync_count += 1
            if pdo.sync_count >= pdo.trans_type:
                pdo.sync_count = 0
                self._emit(pdo, self._pack(pdo), now)

    def acyclic_due(self, pdo: Pdo, data: bytes) -> bool:
        """Hook: whether a TPDO of transmission type 0 is sent at this SYNC with ``data``.
        Default (CiA 301, acyclic synchronous): when its data changed."""
        return data != pdo.last_data

    def poll_events(self) -> None:
        """After anything that may change values: event-driven TPDOs whose data changed."""
        if not self._event_tpdos or not self._tpdo_allowed():
            return
        now = time.monotonic()
        for pdo in self._event_tpdos:
            self._send_event(pdo, now, force=False)

    def _send_event(self, pdo: Pdo, now: float, force: bool) -> None:
        data = self._pack(pdo)
        if not force and not self.has_changed(pdo, data):
            return
        if pdo.inhibit and pdo.last_data is not None and now < pdo.last_time + pdo.inhibit:
            if pdo.deferred is None:
                pdo.deferred = self._timers.call_at(pdo.last_time + pdo.inhibit,
                                                    lambda: self._on_deferred(pdo))
            return
        self._emit(pdo, data, now)

    # A device whose event-driven TPDO1..4 are filtered by change masks (two 32-bit words per
    # channel at this index + channel - 1, sub-indices 1 and 2: only masked bits count) sets it.
    change_masks: int | None = None

    def has_changed(self, pdo: Pdo, data: bytes) -> bool:
        """Hook: whether an event-driven TPDO's data changed enough to be sent (by default any
        change; with ``change_masks`` only a change in the masked bits or in the length)."""
        last = pdo.last_data
        if last is None or self.change_masks is None or not pdo.transmit or pdo.number > 4:
            return data != last
        values = self._store.values
        index = self.change_masks + pdo.number - 1
        mask = values.get(key(index, 1), 0xFFFFFFFF) | values.get(key(index, 2), 0xFFFFFFFF) << 32
        changed = int.from_bytes(data, 'little') ^ int.from_bytes(last, 'little')
        return bool(changed & mask) or len(data) != len(last)

    def _on_deferred(self, pdo: Pdo) -> None:
        with self._lock:
            pdo.deferred = None
            if pdo.valid and self._tpdo_allowed():
                self._send_event(pdo, time.monotonic(), force=False)

    def _on_event_timer(self, pdo: Pdo) -> None:
        with self._lock:
            pdo.event_handle = None
            if pdo.valid and not pdo.synchronous and self._tpdo_allowed():
                self._emit(pdo, self._pack(pdo), time.monotonic())

    def _emit(self, pdo: Pdo, data: bytes, now: float) -> None:
        pdo.last_data = data
        pdo.last_time = now
        self.tpdo_sent += 1
        self._send(pdo.cob_id, data)
        if pdo.event_timer and not pdo.synchronous:
            if pdo.event_handle is not None:
                pdo.event_handle.cancel()
            pdo.event_handle = self._timers.call_at(now + pdo.event_timer, lambda: self._on_event_timer(pdo))
