"""Supervision of the bus and its nodes: CiA 301 error control (heartbeat consumer, node
guarding), TPDO freshness, bus errors and reopening, floods of unknown frames, the SDO part of
a run-on stop, and the boot-up of the nodes (scheduling, retries, booting again a node that
came back). Thread: the supervisor (``drive_bridge-supervisor``, every SUPERVISOR_PERIOD), one
short-lived thread per node boot, and the Notifier for the node-state listener.

The :class:`Supervisor` reaches the Master only through what its constructor is given: the
nodes and axes, the bus health, emitting an event, one boot attempt, the cycle's SYNC count and
hooks for the bus going down and coming back (docs/architecture.md, Threads).
"""
from __future__ import annotations

import functools
import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from typing import Protocol

from drive_bridge.cia301.nmt import NmtState
from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint import JointDriver
from drive_bridge.master.boot import repeats_identically
from drive_bridge.master.bus import BusHealth
from drive_bridge.master.errors import BootError
from drive_bridge.master.events import EventKind, Level
from drive_bridge.master.guarding import GuardEventKind
from drive_bridge.master.node import BootState, NodeRuntime
from drive_bridge.master.run_on import RunOnStop

log = logging.getLogger('drive_bridge.master')

SUPERVISOR_PERIOD = 0.02
SUPERVISION_ERROR_PERIOD = 10.0  # s between two reports of the same failing supervision step
BUS_DOWN_AFTER = 0.1  # s a bus must keep failing to count as down (a single glitch is only counted)
BUS_REOPEN_AFTER = 1.0  # s of a failing bus before the master reopens an interface it opened


class Emit(Protocol):
    """The Master's event: kept in its recent events and given to its listeners."""

    def __call__(self, kind: EventKind, level: Level, message: str, node: NodeRuntime | None = None) -> None: ...


class Supervisor:
    """Watches what did not come (a heartbeat, a guarding reply, a TPDO, a working bus) and
    reacts: a node lost, held, back or configured again. :meth:`run` is the supervisor thread."""

    def __init__(self, *, nodes: Mapping[str, NodeRuntime], axes: Mapping[str, JointDriver], channel: str,
                 stop: threading.Event, emit: Emit,
                 boot_node: Callable[[NodeRuntime], None], bus_health: Callable[[], BusHealth | None],
                 reopen_bus: Callable[[], bool], on_bus_down: Callable[[], None], on_bus_back: Callable[[], None],
                 sync_count: Callable[[], int], unknown_frames: Callable[[float], str | None],
                 run_on: RunOnStop) -> None:
        self._nodes = nodes
        self._axes = axes
        self._channel = channel
        self._stop = stop
        self._emit = emit
        self._boot_node = boot_node  # one attempt; BootError when the node refuses
        self._bus_health = bus_health  # None: the bus is not open
        self._reopen_bus = reopen_bus  # False: not the Master's to reopen (the caller passed it in)
        self._on_bus_down = on_bus_down
        self._on_bus_back = on_bus_back
        self._sync_count = sync_count
        self._unknown_frames = unknown_frames
        self._run_on = run_on
        self._supervision_errors: dict[str, float] = {}  # subject -> monotonic time last reported
        self._boot_threads: dict[str, threading.Thread] = {}
        self._last_reopen = 0.0
        self.bus_down = False  # the bus failed (bus-off, interface errors) and has not come back

    def join_boots(self, timeout: float) -> None:
        """Wait for the boot threads still running (after the stop event)."""
        for thread in list(self._boot_threads.values()):
            thread.join(timeout=timeout)

    def run(self) -> None:
        """The supervisor thread's body, until the stop event is set."""
        for node in self._nodes.values():
            node.add_state_listener(functools.partial(self._on_node_state, node))
        while not self._stop.wait(SUPERVISOR_PERIOD):
            now = time.monotonic()
            try:
                if self._check_bus(now):
                    continue  # nothing on a dead bus can be judged
                unknown = self._unknown_frames(now)
                if unknown:
                    self._emit(EventKind.UNKNOWN_FRAMES, Level.WARN, f'bus {self._channel}: {unknown}')
            except Exception as exc:  # supervision goes on: the next round tries again
                self._supervision_failed(f'bus {self._channel}', exc, now)
                continue
            for node in self._nodes.values():
                try:
                    self._check_heartbeat(node, now)
                    self._check_guarding(node, now)
                    self._check_freshness(node, now)
                    if self._run_on.sdo_due(node):
                        try:
                            node.family_node.stop_run_on(by_sdo=True)
                        except DriveBridgeError as exc:
                            self._run_on.sdo_failed(node, exc)
                    if node.boot_state in (BootState.WAITING, BootState.FAILED) and now >= node.next_boot_time:
                        self._start_boot(node)
                except Exception as exc:  # the other nodes are still supervised
                    self._supervision_failed(f'node {node.node_id} ({node.name})', exc, now, node)

    def _supervision_failed(self, what: str, exc: Exception, now: float, node: NodeRuntime | None = None) -> None:
        """An unexpected error in one supervision step: logged every time, an ERROR event at
        most every SUPERVISION_ERROR_PERIOD per subject (a step failing each round floods nothing)."""
        log.exception('supervising %s failed', what)
        if now - self._supervision_errors.get(what, -math.inf) >= SUPERVISION_ERROR_PERIOD:
            self._supervision_errors[what] = now
            self._emit(EventKind.ERROR, Level.ERROR,
                       f'{what}: supervision step failed: {exc!r} (retried every {SUPERVISOR_PERIOD * 1000:.0f} ms; '
                       f'reported at most every {SUPERVISION_ERROR_PERIOD:g} s)', node)

    def _check_bus(self, now: float) -> bool:
        """Bus-off or a failing interface: report once, every node unavailable (streams abort,
        intents dropped); when the bus works again, configure every node again (the axes stay
        disabled until enabled). True while the bus is down."""
        health = self._bus_health()
        if health is None:
            return False
        channel = self._channel
        if health.failing and not self.bus_down and now - health.failing_since >= BUS_DOWN_AFTER:
            self._on_bus_down()  # the kernel's SYNC stops, restarted on the interface that works again
            self.bus_down = True
            for node in self._nodes.values():
                self._reset_axes(node)
                if node.boot_state in (BootState.OPERATIONAL, BootState.STALE, BootState.LOST):
                    node.set_boot_state(BootState.LOST, f'bus error: {health.last_error or "controller error state"}')
            self._emit(EventKind.BUS_ERROR, Level.ERROR,
                       f'bus {channel}: {health.last_error or "CAN controller in error state (bus-off)"}; '
                       'every node unavailable, streams stopped, until the bus returns', None)
        elif health.failing and self.bus_down:
            self._reopen(now, health.failing_since)
        elif self.bus_down:
            self._on_bus_back()
            self.bus_down = False
            for node in self._nodes.values():
                if node.boot_state is not BootState.BOOTING:
                    self._reset_axes(node)
                    node.set_boot_state(BootState.WAITING)
                    node.next_boot_time = 0.0
            self._emit(EventKind.BUS_BACK, Level.WARN,
                       f'bus {channel}: working again (receive {health.recv_errors}, send {health.send_errors} '
                       f'error(s), {health.error_frames} error frame(s) so far); configuring every node again '
                       '(axes stay disabled until enabled)', None)
        return self.bus_down

    def _reopen(self, now: float, failing_since: float) -> None:
        """While the bus keeps failing, the Master reopens an interface it opened itself, at
        most every BUS_REOPEN_AFTER."""
        if now - max(failing_since, self._last_reopen) < BUS_REOPEN_AFTER:
            return
        if self._reopen_bus():
            self._last_reopen = now

    def _check_freshness(self, node: NodeRuntime, now: float) -> None:
        """A node alive by heartbeat (or guarding) whose cyclic TPDO stopped: its axes are held
        (HALT, so the cycle still tells the drive to stay put) and it is unavailable until the
        TPDO is back. A node not started sends no TPDO by right (the clocks restart; a stale one
        that left OPERATIONAL is configured again), and a silent one is for liveness to judge."""
        syncs = self._sync_count()
        if node.boot_state not in (BootState.OPERATIONAL, BootState.STALE):
            return
        if node.nmt_state is not NmtState.OPERATIONAL:
            node.freshness.arm(now, syncs)
            if node.boot_state is BootState.STALE:  # alive but not started: configure again
                self._reset_axes(node)
                node.set_boot_state(BootState.WAITING)
                node.next_boot_time = 0.0
            return
        if not self._answers(node, now):
            return
        stale = node.freshness.poll(now, syncs)
        if stale and node.boot_state is BootState.OPERATIONAL:
            joints = [a.joint for a in node.config.axes]
            for joint in joints:
                try:
                    self._axes[joint].halt(True)
                except Exception as exc:  # holding goes on for the other joints
                    log.warning('holding %s: %s', joint, exc)
            reason = '; '.join(str(s) for s in stale)
            node.set_boot_state(BootState.STALE, reason)
            alive = 'it answers node guarding' if node.guard is not None else 'its heartbeat continues'
            self._emit(EventKind.PDO_STALE, Level.ERROR,
                       f'node {node.node_id} ({node.name}): {reason} while {alive}; '
                       f'joint(s) {", ".join(joints)} held (HALT), streams aborted', node)
        elif not stale and node.boot_state is BootState.STALE:
            node.set_boot_state(BootState.OPERATIONAL)
            self._emit(EventKind.PDO_FRESH, Level.WARN,
                       f'node {node.node_id} ({node.name}): TPDOs fresh again; its axes stay held '
                       '(HALT) until resumed', node)

    @staticmethod
    def _answers(node: NodeRuntime, now: float) -> bool:
        """Its last heartbeat or guarding reply is at most two of its periods old: a node that
        fell silent is judged by liveness (heartbeat or guarding lost), not by its TPDOs."""
        cfg = node.config
        period = (cfg.guard_time_ms if node.guard is not None else cfg.heartbeat_producer_ms) / 1000.0
        if period <= 0 or node.last_heartbeat is None:
            return True
        return now - node.last_heartbeat <= 2 * period

    def _on_node_state(self, node: NodeRuntime) -> None:
        """A heartbeat or boot-up arrived (Notifier thread): notice unexpected reboots; a node
        whose boot failed (also permanently) and sends a boot-up (reset, a replaced drive) is
        booted again at once."""
        if node.bootup_seen.is_set() and node.boot_state is BootState.FAILED:
            node.bootup_seen.clear()
            node.boot_refusal = None
            node.next_boot_time = 0.0
            return
        if node.bootup_seen.is_set() and node.boot_state in (BootState.OPERATIONAL, BootState.LOST,
                                                             BootState.STALE):
            node.bootup_seen.clear()
            self._reset_axes(node)
            node.set_boot_state(BootState.WAITING)
            node.next_boot_time = 0.0
            self._emit(EventKind.UNEXPECTED_BOOT, Level.WARN,
                       f'node {node.node_id} ({node.name}) sent a boot-up message while operational '
                       '(reset or power cycle); configuring it again', node)

    def _check_heartbeat(self, node: NodeRuntime, now: float) -> None:
        if not node.heartbeat_timeout or node.last_heartbeat is None:
            return
        age = now - node.last_heartbeat
        if node.boot_state in (BootState.OPERATIONAL, BootState.STALE) and age > node.heartbeat_timeout:
            node.set_boot_state(BootState.LOST, f'heartbeat lost: none for {age * 1000:.0f} ms')
            self._emit(EventKind.HEARTBEAT_LOST, Level.ERROR,
                       f'node {node.node_id} ({node.name}): heartbeat lost, none for {age * 1000:.0f} ms '
                       f'(limit {node.heartbeat_timeout * 1000:.0f} ms); its axes are unavailable', node)
        elif node.boot_state is BootState.LOST and age < node.heartbeat_timeout:
            if node.nmt_state is NmtState.OPERATIONAL:
                node.set_boot_state(BootState.OPERATIONAL)
                self._emit(EventKind.HEARTBEAT_BACK, Level.WARN,
                           f'node {node.node_id} ({node.name}): heartbeat back, node operational', node)
            else:  # alive but not started (e.g. reset to pre-operational): configure again
                self._reset_axes(node)
                node.set_boot_state(BootState.WAITING)
                node.next_boot_time = 0.0

    def _check_guarding(self, node: NodeRuntime, now: float) -> None:
        """Poll node guarding (sends the RTR when due) and act on what it reports: lost
        -> the node's axes are unavailable; back -> configured again, never re-enabled."""
        guard = node.guard
        if guard is None or not node.guard_active:
            return
        for event in guard.poll(now):
            if event.kind is GuardEventKind.LOST and node.boot_state in (BootState.OPERATIONAL, BootState.STALE):
                node.set_boot_state(BootState.LOST, f'node guarding lost: {event.message}')
                self._emit(EventKind.GUARDING_LOST, Level.ERROR,
                           f'{event.message} ({node.name}); its axes are unavailable', node)
            elif event.kind is GuardEventKind.TOGGLE_ERROR:
                self._emit(EventKind.GUARDING_ERROR, Level.WARN, f'{event.message} ({node.name})', node)
            elif event.kind is GuardEventKind.BACK and node.boot_state in (BootState.LOST, BootState.STALE):
                self._emit(EventKind.GUARDING_BACK, Level.WARN,
                           f'{event.message} ({node.name}): answers again; configuring it again '
                           '(its axes stay disabled until enabled)', node)
                self._reset_axes(node)
                node.set_boot_state(BootState.WAITING)
                node.next_boot_time = 0.0
        state, age = guard.nmt_state, guard.age(now)
        if state is not None and age is not None and not guard.lost:
            node.on_guard_reply(state, age)

    def _reset_axes(self, node: NodeRuntime) -> None:
        for axis_cfg in node.config.axes:
            self._axes[axis_cfg.joint].on_node_reset()

    def _settle_axes(self, node: NodeRuntime) -> None:
        """After a boot: each axis driver that settles its mode from the drive (0x6502) does so
        and says which (boot thread)."""
        for axis_cfg in node.config.axes:
            settle = getattr(self._axes[axis_cfg.joint], 'on_booted', None)
            if settle is None:
                continue
            try:
                line = settle()
                if line:
                    self._emit(EventKind.CONFIGURED, Level.INFO, line, node)
            except DriveBridgeError as exc:
                self._emit(EventKind.ERROR, Level.WARN, f'{axis_cfg.joint}: modes not read: {exc}', node)

    def _start_boot(self, node: NodeRuntime) -> None:
        node.set_boot_state(BootState.BOOTING)
        thread = threading.Thread(target=self._boot, args=(node,), daemon=True,
                                  name=f'drive_bridge-boot-{node.node_id}')
        self._boot_threads[node.name] = thread
        thread.start()

    def _boot(self, node: NodeRuntime) -> None:
        attempts = 1 + max(0, node.config.timeouts.boot_retries)
        error = ''
        for _ in range(attempts):
            if self._stop.is_set():
                return
            node.boot_attempts += 1
            try:
                self._boot_node(node)
            except BootError as exc:
                error = str(exc)
                log.info('boot attempt %d failed: %s', node.boot_attempts, error)
                # the previous refusal is kept across rounds: also with boot_retries 0
                previous, node.boot_refusal = node.boot_refusal, exc
                if repeats_identically(exc, previous):
                    node.bootup_seen.clear()  # the boot's own boot-up; a later one is a new drive
                    node.next_boot_time = math.inf
                    node.set_boot_state(BootState.FAILED, error)
                    self._emit(EventKind.BOOT_FAILED, Level.ERROR,
                               f'{error} (the same refusal on {node.boot_attempts} attempts: permanent, not '
                               'retried; change the configuration)', node)
                    return
                continue
            except Exception as exc:  # never let a boot thread die silently
                error = f'node {node.node_id} ({node.name}) boot failed unexpectedly: {exc!r}'
                continue
            node.bootup_seen.clear()  # the boot's own boot-up; a later one is a real reboot
            node.boot_refusal = None
            self._settle_axes(node)
            node.set_boot_state(BootState.OPERATIONAL)
            self._emit(EventKind.BOOTED, Level.INFO,
                       f'node {node.node_id} ({node.name}) booted and operational '
                       f'(attempt {node.boot_attempts})', node)
            return
        interval = node.config.timeouts.boot_retry_interval
        node.bootup_seen.clear()
        node.next_boot_time = time.monotonic() + interval
        node.set_boot_state(BootState.FAILED, error)
        self._emit(EventKind.BOOT_FAILED, Level.ERROR,
                   f'{error} (after {attempts} attempt(s); retrying in {interval:g} s)', node)
