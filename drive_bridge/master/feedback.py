"""When have the drives answered this cycle's SYNC?

Each available node's synchronous TPDOs (transmission type 1: one per SYNC) are armed
right before SYNC and ticked off as they arrive (in the CAN thread). When the last one
is in, the cycle thread may decide the next set-points on fresh feedback and the
listeners (the joint states) run at once instead of a period later, at the next SYNC.
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Iterable

import canopen

from drive_bridge.master.node import NodeRuntime

SYNC_EVERY_CYCLE = 1


class CycleFeedback:
    """The synchronous TPDOs still due this cycle; ``wait`` blocks until none is."""

    def __init__(self) -> None:
        self._nodes: list[tuple[NodeRuntime, frozenset[int]]] = []
        self._pending: set[int] = set()
        self._complete = threading.Event()
        self._complete.set()
        self._listeners: list[Callable[[], None]] = []
        self.completed = 0  # cycles whose TPDOs all arrived

    def watch(self, network: canopen.Network, nodes: Iterable[NodeRuntime]) -> None:
        for node in nodes:
            cobs = frozenset(cob for cob, layout in node.process.rx_layouts.items()
                             if layout.config.transmission == SYNC_EVERY_CYCLE)
            if cobs:
                self._nodes.append((node, cobs))
                for cob in cobs:
                    network.subscribe(cob, self._on_tpdo)

    def add_listener(self, listener: Callable[[], None]) -> None:
        """Called in the CAN thread once per cycle, when the cycle's last synchronous TPDO is in."""
        self._listeners = [*self._listeners, listener]

    def arm(self, _cycle: int) -> None:
        """Right before SYNC: every available node's synchronous TPDOs are due."""
        pending: set[int] = set()
        for node, cobs in self._nodes:
            if node.available:
                pending.update(cobs)
        if pending:  # cleared before the new set is visible: a TPDO completing it sets it again
            self._complete.clear()
            self._pending = pending
        else:
            self._pending = pending
            self._complete.set()

    def wait(self, timeout: float) -> bool:
        return self._complete.wait(timeout)

    def _on_tpdo(self, cob_id: int, _data: bytearray, _timestamp: float) -> None:
        pending = self._pending
        if cob_id not in pending:
            return
        pending.discard(cob_id)
        if pending or self._complete.is_set():
            return
        self._complete.set()
        self.completed += 1
        for listener in self._listeners:
            listener()
