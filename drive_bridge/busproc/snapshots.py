"""The whole bus's snapshot in the node process (``Master.snapshot()``'s stand-in): the one the
bus process last sent, with the joints' fresher local snapshots; each read asks for the next
one without waiting, so a reader at the diagnostics period sees a snapshot at most one period
old and never blocks on the bus process."""
from __future__ import annotations

import concurrent.futures
import dataclasses
import threading

from drive_bridge.busproc.intents import Query
from drive_bridge.busproc.ports import SnapshotClient
from drive_bridge.cia301.nmt import NmtState
from drive_bridge.master.busload import BusTraffic
from drive_bridge.master.master import BusSnapshot
from drive_bridge.master.node import BootState, NodeSnapshot

FIRST_WAIT = 2.0  # s the first read waits for the bus process's answer


class SnapshotCache:
    def __init__(self, client: SnapshotClient) -> None:
        self.client = client
        self._last: BusSnapshot | None = None
        self._asking: concurrent.futures.Future[object] | None = None
        self._lock = threading.Lock()

    def get(self) -> BusSnapshot:
        client = self.client
        if client.final is not None:  # the bus process ended on request: its last word
            return dataclasses.replace(client.final, axes=tuple(axis.snapshot() for axis in client.axes.values()))
        if self._last is None and not client.lost:
            try:
                self._keep(client.call(Query('snapshot'), FIRST_WAIT))
            except Exception:
                pass
        elif not client.lost:
            self._ask()
        last = self._last or self._empty()
        if client.lost:
            last = dataclasses.replace(last, bus_state='LOST', nodes=tuple(
                dataclasses.replace(n, available=False, boot_state=BootState.LOST, boot_error=client.lost)
                for n in last.nodes))
        return dataclasses.replace(last, axes=tuple(axis.snapshot() for axis in client.axes.values()))

    def _ask(self) -> None:
        with self._lock:
            if self._asking is not None and not self._asking.done():
                return
            self._asking = future = self.client.call_async(Query('snapshot'))
        future.add_done_callback(lambda f: self._keep(f.result()) if f.exception() is None else None)

    def _keep(self, value: object) -> None:
        if isinstance(value, BusSnapshot):
            self._last = value

    def _empty(self) -> BusSnapshot:
        """Before the bus process answered: every configured node, not booted yet."""
        nodes = tuple(NodeSnapshot(name=n.name, node_id=n.node_id, family=n.config.family,
                                   boot_state=BootState.WAITING, nmt_state=NmtState.UNKNOWN, available=False,
                                   heartbeat_age=None, boot_attempts=0, boot_error='', sdo_errors=0,
                                   last_sdo_error='', pdo_errors=0, last_pdo_error='', emcy=())
                      for n in self.client.nodes.values())
        return BusSnapshot(nodes=nodes, axes=(), sync=None, bus_state='STARTING',
                           channel=str(self.client.config.bus.channel), traffic=BusTraffic(0, 0, 0.0, 0.0))
