"""The SYNC consumer and the model clock of a simulated slave.

A SYNC frame advances the device model by the time since the last one (the producer's frame
stamps), latches RPDOs and sends the synchronous TPDOs; without SYNC for a while the node's
own tick (every ``TICK_PERIOD``) advances it. The tick also runs the supervision of a booted
node: heartbeat consumer, life guarding and the device's own checks.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable

from drive_bridge.sim.commobjects import COB_ID_SYNC, CYCLE_PERIOD
from drive_bridge.sim.guardresponder import GuardingResponder
from drive_bridge.sim.heartbeat import HeartbeatMonitor
from drive_bridge.sim.nmtslave import NmtSlave
from drive_bridge.sim.parts import Callback, SlaveNode
from drive_bridge.sim.store import key
from drive_bridge.sim.synccost import SyncCost
from drive_bridge.sim.timers import Periodic, TimerThread

TICK_PERIOD = 0.010  # s: the model's own clock when no SYNC arrives
SYNC_SILENCE = 0.050  # s without SYNC before the tick advances the model
MAX_STEP = 0.1  # s: a model step never covers more than this (pauses, stalls)


class SyncClock:
    """SYNC subscription (0x1005), the measured SYNC period and the model's tick."""

    def __init__(self, node: SlaveNode, nmt: NmtSlave, timers: TimerThread, *, monitor: HeartbeatMonitor,
                 guarding: GuardingResponder, subscribe: Callable[[int, Callback], None],
                 unsubscribe: Callable[[int, Callback], None]) -> None:
        self._node = node
        self._nmt = nmt
        self._monitor = monitor
        self._guarding = guarding
        self._subscribe = subscribe
        self._unsubscribe = unsubscribe
        self._tick = Periodic(timers, self._on_tick)
        self._cob: int | None = None
        self.received_count = 0
        self.cost = SyncCost()
        self._prev_stamp: float | None = None
        self.period = 0.0  # s, measured (moving average of SYNC intervals)
        self.last_sync = -math.inf
        self.last_advance = time.monotonic()

    def start(self) -> None:
        """Power-on: the model's time starts now and the tick runs."""
        self.last_advance = time.monotonic()
        self._tick.start(TICK_PERIOD)

    def stop(self) -> None:
        self._tick.stop()

    def update_subscription(self) -> None:
        """0x1005 written, or boot-up: listen on the COB-ID it holds."""
        cob = self._node.store.values.get(key(COB_ID_SYNC, 0), 0x80) & 0x7FF
        if cob != self._cob:
            if self._cob is not None:
                self._unsubscribe(self._cob, self.on_sync)
            self._subscribe(cob, self.on_sync)
            self._cob = cob

    def forget(self) -> None:
        """The node left the bus (its subscriptions are gone)."""
        self._cob = None

    def on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        start = time.perf_counter()
        node = self._node
        with node.lock:
            if node.faults.muted or not self._nmt.communicating:
                return
            self.received_count += 1
            now = time.monotonic()
            if self._prev_stamp is not None and now - self.last_sync < self.silence():
                dt = timestamp - self._prev_stamp  # frame stamps: the producer's timing, not ours
                self.period = dt if not self.period else 0.9 * self.period + 0.1 * dt
            else:
                dt = now - self.last_advance
            self._prev_stamp = timestamp
            self.last_sync = self.last_advance = now
            operational = self._nmt.operational
            pdo = node.pdo
            if operational:
                pdo.apply_latched()
            pdo.open_window(timestamp)
            node.model_step(min(max(dt, 0.0), MAX_STEP), True)
            if operational:
                pdo.transmit_on_sync(data[0] if len(data) else None)
                pdo.poll_events()
            self.cost.add(time.perf_counter() - start)

    def silence(self) -> float:
        """How long without SYNC before the drive's own clock takes over (3 cycles of 0x1006, >= 50 ms)."""
        return max(SYNC_SILENCE, 3e-6 * self._node.store.values.get(key(CYCLE_PERIOD, 0), 0))

    def cycle_period(self) -> float:
        """The SYNC cycle as the device knows it: 0x1006 if set, else measured, else 4 ms."""
        configured = self._node.store.values.get(key(CYCLE_PERIOD, 0), 0)
        if configured:
            return float(configured * 1e-6)
        return self.period or 0.004

    def _on_tick(self) -> None:
        node = self._node
        with node.lock:
            if not self._nmt.powered:
                return
            now = time.monotonic()
            booted = self._nmt.booted
            if booted:
                self._monitor.check(now)
            if now - self.last_sync >= self.silence():
                dt, self.last_advance = now - self.last_advance, now
                node.model_step(min(max(dt, 0.0), MAX_STEP), False)
                node.pdo.poll_events()
            if booted:
                changed = self._guarding.check(now)
                if node.supervise(now) or changed:
                    node.pdo.poll_events()
