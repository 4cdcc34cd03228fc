"""The SYNC cycle of one bus: who produces the SYNC (the master's own producer thread, the
kernel's periodic send, or another node) and what runs around each one: the set-points and
RPDOs for the next SYNC before it, the cycle listeners after it.

The cycle never owns the bus or the nodes: the Master hands in what it reads of them.
"""
from __future__ import annotations

import time
from collections.abc import Callable

import canopen

from drive_bridge.joint import JointDriver
from drive_bridge.master.bus import TappedBus
from drive_bridge.master.events import EventKind, Level
from drive_bridge.master.feedback import CycleFeedback
from drive_bridge.master.kernelsync import KernelSync
from drive_bridge.master.node import BootState, NodeRuntime
from drive_bridge.master.realtime import SwitchInterval, make_realtime
from drive_bridge.master.run_on import RunOnStop
from drive_bridge.master.sync import SYNC_COB_ID, SyncProducer
from drive_bridge.model import MasterConfig

Emit = Callable[[EventKind, Level, str], None]


class Cycle:
    """Started with the bus open (:meth:`start`), stopped after the nodes' last set-points
    (:meth:`stop`); ``sync`` is the master's producer (None when another node or the kernel
    produces SYNC), ``kernel_sync`` the kernel's periodic send (``sync_producer: kernel``)."""

    def __init__(self, config: MasterConfig, network: canopen.Network, *, nodes: dict[str, NodeRuntime],
                 axes: dict[str, JointDriver], feedback: CycleFeedback, run_on: RunOnStop, emit: Emit,
                 bus: Callable[[], TappedBus | None], bus_down: Callable[[], bool]) -> None:
        self._config = config
        self._network = network
        self._nodes = nodes
        self._axes = axes
        self._feedback = feedback
        self._run_on = run_on
        self._emit = emit
        self._bus = bus
        self._bus_down = bus_down
        self._switch_interval = SwitchInterval()
        self._listeners: list[Callable[[int], None]] = []
        self._external_count = 0  # SYNCs seen when another node produces them
        self.sync: SyncProducer | None = None
        self.kernel_sync: KernelSync | None = None

    def add_listener(self, listener: Callable[[int], None]) -> None:
        """Called after each cycle's SYNC and set-points (cycle thread, keep it short)."""
        self._listeners = [*self._listeners, listener]

    def count(self) -> int:
        """The SYNCs of this cycle so far (sent, or seen from another producer)."""
        return self.sync.cycles if self.sync is not None else self._external_count

    def start(self) -> None:
        master = self._config
        bus = self._bus()

        def on_error(text: str) -> None:
            failing = self._bus()
            if not self._bus_down() and not (failing is not None and failing.health().failing):
                self._emit(EventKind.ERROR, Level.ERROR, text)  # a failing bus: once, as BUS_ERROR
        if master.sends_sync and master.sync_producer in ('external', 'kernel'):
            self._external_count = 0  # the cycle follows each SYNC received (kernel: looped back)
            self._network.subscribe(SYNC_COB_ID, self._on_external_sync)
            if master.sync_producer == 'kernel' and bus is not None:
                self.kernel_sync = KernelSync(bus, master.sync_period)
                self.kernel_sync.start()
            return
        self.sync = SyncProducer(self._network.send_message, master.cycle_period, send_sync=master.sends_sync,
                                 on_error=on_error, feedback=self._feedback.wait if master.sends_sync else None,
                                 sync_window=master.sync_window if master.sends_sync else None,
                                 on_start=self._realtime if master.realtime_priority is not None else None)
        self.sync.add_at_sync(self._feedback.arm)
        self.sync.add_before_sync(self._before_sync)
        self.sync.add_after_sync(self._after_sync)
        self.sync.start()

    def stop(self) -> None:
        if self.sync is not None:
            self.sync.stop()
        self._switch_interval.restore()
        if self.kernel_sync is not None:
            self.kernel_sync.stop()

    def run_kernel_sync(self, run: bool) -> None:
        """The bus went down (False) or came back (True): the kernel's SYNC follows it."""
        if self.kernel_sync is not None:
            (self.kernel_sync.start if run else self.kernel_sync.stop)()

    def _realtime(self) -> None:
        """In the cycle thread, before its first SYNC: SCHED_FIFO at master.realtime_priority."""
        priority = self._config.realtime_priority
        assert priority is not None
        self._switch_interval.lower()
        problem = make_realtime(priority)
        if problem is not None:
            self._emit(EventKind.CONFIGURED, Level.WARN,
                       f'master.realtime_priority {priority}: SCHED_FIFO refused for the cycle thread '
                       f'({problem}); it runs at normal priority')
        else:
            self._emit(EventKind.CONFIGURED, Level.INFO,
                       f'cycle thread runs SCHED_FIFO at priority {priority} (master.realtime_priority)')

    def _on_external_sync(self, _can_id: int, _data: bytearray, _timestamp: float) -> None:
        """Another node (or the kernel) produced SYNC: send the RPDOs for the next one right away."""
        cycle = self._external_count
        self._external_count += 1
        self._feedback.arm(cycle)
        self._after_sync(cycle)
        self._before_sync(cycle + 1)

    def _before_sync(self, cycle: int) -> None:
        now = self.sync.scheduled_time if self.sync is not None else time.time()
        for node in self._nodes.values():
            if self._run_on.due(node):  # a drive that runs on by itself, lost while it sends: its stop
                if node.family_node.stop_run_on(by_sdo=False):
                    self._run_on.at_rest(node)
                for cob_id, data in node.process.frames():
                    self._network.send_message(cob_id, data)
                continue
            if not node.available and node.boot_state is not BootState.STALE:
                continue  # a stale node is still sent to: its axes are held by HALT
            axes = [self._axes[a.joint] for a in node.config.axes]
            if not all(axis.ready for axis in axes):
                continue  # no statusword yet: no controlword can be decided safely
            for axis in axes:
                axis.on_cycle(now)
            for cob_id, data in node.process.frames():
                self._network.send_message(cob_id, data)

    def _after_sync(self, cycle: int) -> None:
        for listener in self._listeners:
            listener(cycle)

