"""The PDO engine of a simulated slave: CiA 301 rules for PDO parameters, RPDO
latch/apply, TPDO on SYNC, on change (inhibit time) and by event timer.

canopen's LocalNode only decodes received RPDOs into ``PdoMap.data`` and never sends
a TPDO by itself (ecosystem doc §1.1), and ``PdoVariable.raw`` is slow (§1.3). Each
PDO is therefore compiled (:mod:`~drive_bridge.sim.pdocodec`) whenever its parameters are
written, and the writes are checked by :mod:`~drive_bridge.sim.pdoparams`.

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
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

from canopen.objectdictionary import ODVariable

from drive_bridge.sim.pdocodec import COB_INVALID, RPDO_COMM, TPDO_COMM, Pdo, compile_pdo, decode, pack
from drive_bridge.sim.pdoparams import check_mapping_entry, check_parameter_write
from drive_bridge.sim.store import ObjectStore, key
from drive_bridge.sim.timers import TimerThread

SYNC_WINDOW = 0x1007
EMCY_PDO_LENGTH = 0x8210


class PdoEngine:
    """All PDOs of one slave. Every method is called with the slave's lock held.

    Hooks a device model's PDO rules override: :meth:`validate` (parameter writes),
    :meth:`mapping_locked`, :meth:`accepted_rpdos`, :meth:`due_rpdos`, :meth:`value_getter`, :meth:`has_changed`,
    :meth:`acyclic_due`.

    What a vendor simulator's engine may use besides (its extension surface; the rest is
    private): ``store``, ``lock``, ``send``, ``write_many``, ``rpdo_allowed`` and ``tpdo_allowed``
    (as the slave handed them in), ``by_index`` (each PDO by its 0x14xx..0x1Axx parameter index),
    ``rx_by_cob`` (the RPDOs received, by COB-ID), :meth:`packed` and :meth:`emit` (a TPDO's data
    and its transmission).
    """

    def __init__(self, store: ObjectStore, *, lock: threading.RLock, timers: TimerThread,
                 send: Callable[[int, bytes], None], write_many: Callable[[list[tuple[int, Any]]], None],
                 subscribe: Callable[[int, Callable], None], unsubscribe: Callable[[int, Callable], None],
                 rpdo_allowed: Callable[[], bool], tpdo_allowed: Callable[[], bool],
                 emcy: Callable[[int], None]) -> None:
        self.store = store
        self.lock = lock
        self._timers = timers
        self.send = send
        self.write_many = write_many
        self._subscribe = subscribe
        self._unsubscribe = unsubscribe
        self.rpdo_allowed = rpdo_allowed
        self.tpdo_allowed = tpdo_allowed
        self._emcy = emcy
        self.rpdos: dict[int, Pdo] = {}
        self.tpdos: dict[int, Pdo] = {}
        self.by_index: dict[int, Pdo] = {}
        for transmit, comm_base, table in ((False, RPDO_COMM, self.rpdos), (True, TPDO_COMM, self.tpdos)):
            for number in range(1, 513):
                comm = comm_base + number - 1
                if key(comm, 1) in store and key(comm + 0x200, 0) in store:
                    pdo = Pdo(transmit, number)
                    table[number] = pdo
                    self.by_index[pdo.comm] = self.by_index[pdo.mapping] = pdo
        self.rx_by_cob: dict[int, Pdo] = {}
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
        for pdo in self.by_index.values():
            self._compile(pdo)
        self._refresh()

    def close(self) -> None:
        for cob in list(self.rx_by_cob):
            self._unsubscribe(cob, self.on_rpdo)
        self.rx_by_cob.clear()
        for pdo in self.by_index.values():
            pdo.cancel_timers()

    def handles(self, index: int) -> bool:
        return index in self.by_index

    def validate(self, index: int, subindex: int, value: int) -> None:
        """Raise the CiA 301 abort for a write the device must refuse."""
        pdo = self.by_index[index]
        locked = self.mapping_locked(pdo, self.store.values[key(pdo.comm, 1)])
        check_parameter_write(self.store, pdo, index, subindex, value, locked=locked, check_entry=self._check_entry)

    def accepted_rpdos(self, valid: list[Pdo]) -> list[Pdo]:
        """Hook: of the valid RPDOs (in number order), those the device receives. Default: all
        (a device with a hardware limit on receive PDOs serves only some)."""
        return valid

    def mapping_locked(self, pdo: Pdo, cob: int) -> bool:
        """Hook: whether the PDO's COB-ID, mapping, inhibit time and SYNC start value are locked
        against changes (CiA 301: while the PDO is valid, ``cob`` its 0x14xx/0x18xx:1). A PDO
        whose EDS makes the COB-ID read-only cannot be made invalid: its mapping stays open."""
        var = self.store.variables.get(key(pdo.comm, 1))
        return not cob & COB_INVALID and var is not None and var.writable

    def check_entry(self, pdo: Pdo, entry: int) -> ODVariable:
        """The mapped variable of mapping ``entry`` for ``pdo``, or the CiA 301 abort (for device
        models with their own mapping write rules)."""
        return self._check_entry(pdo, entry)

    def _check_entry(self, pdo: Pdo, entry: int) -> ODVariable:
        return check_mapping_entry(self.store, pdo, entry)

    def written(self, index: int) -> None:
        """A parameter of this PDO changed: recompile it."""
        pdo = self.by_index[index]
        self._compile(pdo)
        self._refresh()
        if pdo.transmit and pdo.valid and pdo.trans_type >= 254 and self.tpdo_allowed():
            self._send_event(pdo, time.monotonic(), force=True)

    def _compile(self, pdo: Pdo) -> None:
        compile_pdo(pdo, self.store, self.value_getter)

    def value_getter(self, k: int, var: ODVariable) -> Callable[[], Any]:
        """Hook: how a TPDO reads mapped object ``k`` (default: as SDO reads it)."""
        reader = self.store.readers.get(k)
        if reader is not None:
            return reader
        return functools.partial(self.store.values.__getitem__, k)

    def _refresh(self) -> None:
        wanted = {p.cob_id: p for p in self.accepted_rpdos([p for p in self.rpdos.values() if p.valid])}
        for cob in set(self.rx_by_cob) - set(wanted):
            self._unsubscribe(cob, self.on_rpdo)
        for cob in set(wanted) - set(self.rx_by_cob):
            self._subscribe(cob, self.on_rpdo)
        self.rx_by_cob = wanted
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
        for pdo in self.by_index.values():
            pdo.latched = None
            pdo.cancel_timers()

    # ---- RPDO ------------------------------------------------------------------------
    def on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        """Notifier thread: latch a synchronous RPDO, apply an event-driven one now."""
        with self.lock:
            if not self.rpdo_allowed():
                return
            pdo = self.rx_by_cob.get(can_id)
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
                self.write_many(decode(pdo, data))
                self.poll_events()

    def open_window(self, timestamp: float) -> None:
        """At SYNC (received at ``timestamp``): the synchronous window of 0x1007 starts."""
        window = self.store.values.get(key(SYNC_WINDOW, 0), 0)
        self._window_end = timestamp + window * 1e-6 if window else math.inf

    def apply_latched(self) -> None:
        """At SYNC: the latched data of the RPDOs due, all stored before any reacts."""
        items: list[tuple[int, Any]] = []
        for pdo in self.due_rpdos():
            if pdo.latched is not None:
                items += decode(pdo, pdo.latched)
                pdo.latched = None
        if items:
            self.write_many(items)

    def due_rpdos(self) -> Iterable[Pdo]:
        """Hook: at SYNC, the RPDOs whose latched data apply now, in the order they are stored.
        Default: every RPDO (types 0..240 alike: at the next SYNC)."""
        return self.rx_by_cob.values()

    # ---- TPDO ------------------------------------------------------------------------
    def packed(self, pdo: Pdo) -> bytes:
        """The TPDO's data from the current values."""
        return pack(pdo, self.store)

    def transmit_on_sync(self, counter: int | None) -> None:
        """Right after SYNC (model already stepped): the synchronous TPDOs that are due."""
        if not self._sync_tpdos or not self.tpdo_allowed():
            return
        now = time.monotonic()
        for pdo in self._sync_tpdos:
            if pdo.trans_type == 0:  # acyclic synchronous: on SYNC, when changed
                data = self.packed(pdo)
                if self.acyclic_due(pdo, data):
                    self.emit(pdo, data, now)
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
                self.emit(pdo, self.packed(pdo), now)

    def acyclic_due(self, pdo: Pdo, data: bytes) -> bool:
        """Hook: whether a TPDO of transmission type 0 is sent at this SYNC with ``data``.
        Default (CiA 301, acyclic synchronous): when its data changed."""
        return data != pdo.last_data

    def poll_events(self) -> None:
        """After anything that may change values: event-driven TPDOs whose data changed."""
        if not self._event_tpdos or not self.tpdo_allowed():
            return
        now = time.monotonic()
        for pdo in self._event_tpdos:
            self._send_event(pdo, now, force=False)

    def _send_event(self, pdo: Pdo, now: float, force: bool) -> None:
        data = self.packed(pdo)
        if not force and not self.has_changed(pdo, data):
            return
        if pdo.inhibit and pdo.last_data is not None and now < pdo.last_time + pdo.inhibit:
            if pdo.deferred is None:
                pdo.deferred = self._timers.call_at(pdo.last_time + pdo.inhibit,
                                                    lambda: self._on_deferred(pdo))
            return
        self.emit(pdo, data, now)

    # A device whose event-driven TPDO1..4 are filtered by change masks (two 32-bit words per
    # channel at this index + channel - 1, sub-indices 1 and 2: only masked bits count) sets it.
    change_masks: int | None = None

    def has_changed(self, pdo: Pdo, data: bytes) -> bool:
        """Hook: whether an event-driven TPDO's data changed enough to be sent (by default any
        change; with ``change_masks`` only a change in the masked bits or in the length)."""
        last = pdo.last_data
        if last is None or self.change_masks is None or not pdo.transmit or pdo.number > 4:
            return data != last
        values = self.store.values
        index = self.change_masks + pdo.number - 1
        mask = values.get(key(index, 1), 0xFFFFFFFF) | values.get(key(index, 2), 0xFFFFFFFF) << 32
        changed = int.from_bytes(data, 'little') ^ int.from_bytes(last, 'little')
        return bool(changed & mask) or len(data) != len(last)

    def _on_deferred(self, pdo: Pdo) -> None:
        with self.lock:
            pdo.deferred = None
            if pdo.valid and self.tpdo_allowed():
                self._send_event(pdo, time.monotonic(), force=False)

    def _on_event_timer(self, pdo: Pdo) -> None:
        with self.lock:
            pdo.event_handle = None
            if pdo.valid and not pdo.synchronous and self.tpdo_allowed():
                self.emit(pdo, self.packed(pdo), time.monotonic())

    def emit(self, pdo: Pdo, data: bytes, now: float) -> None:
        """Send the TPDO with ``data`` now: it becomes its last data; its event timer restarts."""
        pdo.last_data = data
        pdo.last_time = now
        self.tpdo_sent += 1
        self.send(pdo.cob_id, data)
        if pdo.event_timer and not pdo.synchronous:
            if pdo.event_handle is not None:
                pdo.event_handle.cancel()
            pdo.event_handle = self._timers.call_at(now + pdo.event_timer, lambda: self._on_event_timer(pdo))
