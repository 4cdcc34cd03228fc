"""The heartbeat producer (0x1017) and consumer (0x1016) of a simulated slave.

Both run with the node's lock held: the producer on the node's timer thread, the
consumer's frames on the Notifier thread; its timeouts are checked by the SYNC clock's tick
(:meth:`HeartbeatMonitor.check`).
"""
from __future__ import annotations

import time
from collections.abc import Callable

from drive_bridge.sim.commobjects import CONSUMER_HEARTBEAT, PRODUCER_HEARTBEAT
from drive_bridge.sim.nmt import HEARTBEAT_BASE, HeartbeatConsumer
from drive_bridge.sim.nmtslave import NmtSlave
from drive_bridge.sim.parts import Callback, SlaveNode
from drive_bridge.sim.store import key
from drive_bridge.sim.timers import Periodic, TimerThread


class HeartbeatProducer:
    """Sends 0x700 + node with the NMT state every 0x1017 ms while booted."""

    def __init__(self, node: SlaveNode, nmt: NmtSlave, timers: TimerThread) -> None:
        self._node = node
        self._nmt = nmt
        self._periodic = Periodic(timers, self._send)

    def restart(self) -> None:
        """0x1017 written, boot-up or communication objects reloaded: the period follows 0x1017."""
        period_ms = self._node.store.values.get(key(PRODUCER_HEARTBEAT, 0), 0)
        if period_ms and self._nmt.booted:
            self._periodic.start(period_ms / 1000.0)
        else:
            self._periodic.stop()

    def stop(self) -> None:
        self._periodic.stop()

    def _send(self) -> None:
        node = self._node
        with node.lock:
            if not self._nmt.booted or node.faults.heartbeat_stopped:
                return
            node.send(HEARTBEAT_BASE + node.node_id, bytes([int(self._nmt.state)]))


class HeartbeatMonitor:
    """The heartbeat consumer: subscribes to the producers 0x1016 names and reports losses."""

    def __init__(self, node: SlaveNode, nmt: NmtSlave, subscribe: Callable[[int, Callback], None],
                 unsubscribe: Callable[[int, Callback], None]) -> None:
        self._node = node
        self._nmt = nmt
        self._subscribe = subscribe
        self._unsubscribe = unsubscribe
        self.consumer = HeartbeatConsumer()
        self._cobs: list[int] = []

    def update(self) -> None:
        """0x1016 written, or boot-up: watch the producers it names now."""
        store = self._node.store
        entries = {k & 0xFF: v for k in store.keys_between(CONSUMER_HEARTBEAT, CONSUMER_HEARTBEAT)
                   if k & 0xFF and isinstance(v := store.values[k], int)}
        self.consumer.configure(entries)
        cobs = [HEARTBEAT_BASE + node for node in self.consumer.producers]
        for cob in self._cobs:
            if cob not in cobs:
                self._unsubscribe(cob, self._on_heartbeat)
        for cob in cobs:
            if cob not in self._cobs:
                self._subscribe(cob, self._on_heartbeat)
        self._cobs = cobs

    def forget(self) -> None:
        """The node left the bus (its subscriptions are gone)."""
        self._cobs = []

    def check(self, now: float) -> None:
        """Tick while booted: a producer silent past its consumer time is lost (the hook, once)."""
        for producer in self.consumer.expired(now):
            self._node.on_heartbeat_lost(producer)

    @property
    def lost(self) -> bool:
        return self.consumer.is_lost()

    def _on_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        node = self._node
        with node.lock:
            if node.faults.muted or not self._nmt.booted:
                return
            producer = can_id - HEARTBEAT_BASE
            if self.consumer.heartbeat(producer, time.monotonic()) and not self.consumer.is_lost():
                node.on_heartbeat_recovered(producer)
