"""The SDO server of a simulated slave over its object store, as canopen's LocalNode serves
SDO with its SdoServer: canopen's protocol (:class:`~drive_bridge.sim.sdo.SimLocalNode`), the
simulator's object access (dynamic objects, CiA 301 checks, reactions to writes) and the
node's NMT gating, refusals and injected faults."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.nmtslave import NmtSlave
from drive_bridge.sim.parts import SlaveNode
from drive_bridge.sim.pdoparams import PDO_PARAMETERS
from drive_bridge.sim.sdo import SimLocalNode, decode_checked, expedited_download_of, read_checked
from drive_bridge.sim.store import key
from drive_bridge.sim.timers import TimerThread

Effect = Callable[[Any], None]


class ObjectAccess:
    """Writes into the store, checked and acted upon: by SDO one at a time, by RPDOs in one go."""

    def __init__(self, node: SlaveNode) -> None:
        self._node = node
        self._validators: dict[int, Effect] = {}
        self._effects: dict[int, Effect] = {}
        self._early: set[int] = set()

    def register(self, index: int, subindex: int = 0, *, reader: Callable[[], Any] | None = None,
                 validator: Effect | None = None, on_write: Effect | None = None, early: bool = False) -> None:
        """See :meth:`SimulatedSlave.register_object`."""
        store = self._node.store
        k = key(index, subindex)
        if k not in store:
            raise KeyError(f'{self._node.name}: 0x{index:04X}:{subindex:02X} is not in the object dictionary')
        if reader is not None:
            store.readers[k] = reader
        if validator is not None:
            self._validators[k] = validator
        if on_write is not None:
            self._effects[k] = on_write
            if early:
                self._early.add(k)

    def _store_value(self, k: int, value: Any) -> Effect | None:
        """Check and store a written value; returns the reaction still to run (if any)."""
        pdo = self._node.pdo
        index = k >> 8
        pdo_parameter = PDO_PARAMETERS[0] <= index <= PDO_PARAMETERS[1] and pdo.handles(index)
        if pdo_parameter:
            pdo.validate(index, k & 0xFF, value)
        validator = self._validators.get(k)
        if validator is not None:
            validator(value)
        self._node.store.values[k] = value
        if pdo_parameter:
            pdo.written(index)
        return self._effects.get(k)

    def write(self, k: int, value: Any) -> None:
        """One value written by SDO: checked, stored, then acted upon."""
        effect = self._store_value(k, value)
        if effect is not None:
            effect(value)

    def write_many(self, items: list[tuple[int, Any]]) -> None:
        """Values from RPDOs: all stored first, then the reactions run in mapping order,
        as a drive copies a received PDO into its dictionary before its control cycle
        evaluates it (a controlword mapped before the target position sees the new target).
        A refused value (e.g. unsupported mode) keeps the old one, as over SDO."""
        effects = []
        for k, value in items:
            try:
                effect = self._store_value(k, value)
            except SdoAbortedError:
                continue
            if effect is not None:
                if k in self._early:
                    effect(value)
                else:
                    effects.append((effect, value))
        for effect, value in effects:
            effect(value)


class SimSdoService:
    """The node's SDO server: requests on 0x600 + node, responses on 0x580 + node."""

    def __init__(self, node: SlaveNode, nmt: NmtSlave, timers: TimerThread, access: ObjectAccess) -> None:
        self._node = node
        self._nmt = nmt
        self._timers = timers
        self._access = access
        self._request: bytes | None = None  # the SDO request frame being served
        self.local = self.new_local_node()

    def new_local_node(self) -> SimLocalNode:
        """canopen's LocalNode serving this node's id (again after the node id changed)."""
        node = self._node
        return SimLocalNode(node.node_id, node.store.od, self._read, self._write, self._respond)

    def _check_injected_abort(self, index: int, subindex: int) -> None:
        code = self._node.faults.sdo_aborts.get((index, subindex))
        if code is not None:
            raise SdoAbortedError(code)

    def _read(self, index: int, subindex: int, check_readable: bool) -> bytes:
        node = self._node
        with node.lock:
            self._check_injected_abort(index, subindex)
            return read_checked(node.store, index, subindex, check_readable)

    def _write(self, index: int, subindex: int, data: bytes, check_writable: bool) -> None:
        node = self._node
        with node.lock:
            self._check_injected_abort(index, subindex)
            request = self._request
            if request is not None and expedited_download_of(request, index, subindex):
                data = node.expedited_download(index, subindex, bytes(data), request)
            self._access.write(key(index, subindex), decode_checked(node.store, index, subindex, data, check_writable))

    def on_request(self, can_id: int, data: bytearray, timestamp: float) -> None:
        """Notifier thread: an SDO request frame."""
        node = self._node
        with node.lock:
            if node.faults.muted or not self._nmt.communicating:
                return
            refused = node.refuse_sdo_request(bytes(data))
            if refused is not None:
                self._respond(bytes([0x80]) + bytes(data[1:4]) + refused.to_bytes(4, 'little'))
                return
            self._request = bytes(data)
            try:
                self.local.sdo.on_request(can_id, data, timestamp)
            finally:
                self._request = None
            node.pdo.poll_events()  # a write may have changed event-driven TPDO data

    def _respond(self, response: bytes) -> None:
        node = self._node
        cob = 0x580 + node.node_id
        if node.faults.sdo_delay > 0:
            self._timers.call_later(node.faults.sdo_delay, lambda: self._send_locked(cob, response))
        else:
            node.send(cob, response)

    def _send_locked(self, cob: int, data: bytes) -> None:
        with self._node.lock:
            self._node.send(cob, data)
