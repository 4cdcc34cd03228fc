"""A simulated CiA 301 slave: a real participant on a python-can ``virtual`` bus.

Built on canopen's LocalNode for the SDO server protocol, and adds what LocalNode
lacks (ecosystem doc §1.1): boot-up and heartbeat after NMT resets received from the
master, NMT gating of SDO/PDO/EMCY, CiA 301 checks on writes (read-only, missing
sub-indices of arrays, value limits, PDO parameter rules), the PDO engine, EMCY with
error history, the heartbeat consumer, and node guarding with life guarding.

Threads: canopen's Notifier thread runs the frame callbacks, one :class:`TimerThread`
per slave runs everything timed. Both take the slave's lock (an RLock) and never
block while holding it (§1.4); delayed answers are scheduled, never slept.
"""
from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

import can
import canopen
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.model import NodeConfig
from drive_bridge.sim.commobjects import (
    COB_ID_SYNC,
    CONSUMER_HEARTBEAT,
    CYCLE_PERIOD,
    IDENTITY,
    PRODUCER_HEARTBEAT,
    check_consumer_write,
    check_emcy_cob,
    check_history_write,
    check_sync_cob,
)
from drive_bridge.sim.emcy import COB_ID_EMCY, ERROR_HISTORY, ERROR_REGISTER, EmcyProducer
from drive_bridge.sim.faults import CommFaultInjection, CommFaults
from drive_bridge.sim.guarding import EMCY_LIFE_GUARD, NodeGuarding, RemoteFrames, add_guarding_objects
from drive_bridge.sim.nmt import HEARTBEAT_BASE, NMT_COB_ID, HeartbeatConsumer, NmtCommand, NmtState, addressed_command
from drive_bridge.sim.options import SLAVE_OPTIONS, OptionSpec, resolve_options
from drive_bridge.sim.pdo import PDO_PARAMETERS, PdoEngine
from drive_bridge.sim.sdo import SimLocalNode, decode_checked, expedited_download_of, read_checked
from drive_bridge.sim.store import ObjectStore, key
from drive_bridge.sim.synccost import SyncCost
from drive_bridge.sim.timers import Periodic, TimerHandle, TimerThread

logger = logging.getLogger(__name__)

EMCY_HEARTBEAT = 0x8130

TICK_PERIOD = 0.010  # s: the model's own clock when no SYNC arrives
SYNC_SILENCE = 0.050  # s without SYNC before the tick advances the model
MAX_STEP = 0.1  # s: a model step never covers more than this (pauses, stalls)
NOTIFIER_CYCLE = 0.05  # s: Notifier recv timeout of own Networks (canopen's 1 s makes disconnect slow)

Callback = Callable[[int, bytearray, float], None]


class SimulatedSlave(CommFaultInjection):
    """A CiA 301 node backed by its EDS. Subclasses add a device model (``SimDrive402``).

    Life cycle: construct, ``attach(network)`` (shared) or ``connect(channel)`` (own
    Network), ``power_on()``, ..., ``power_off()``, ``close()``.

    A device model or a drive family's simulator changes what its manual says differs
    through these, each with plain CiA 301 as the default (all run with the lock held):

    - data: ``OPTIONS``, ``PDO_ENGINE``, ``EMCY_PRODUCER``, ``NMT_COMMANDS`` (the NMT
      commands the device obeys; others are ignored, as an NMT command cannot be refused);
    - :meth:`announce_bootup` -- how boot-up shows on the bus;
    - :meth:`reset_application` -- power-on / reset node: the application starts again;
    - :meth:`on_reset_communication` -- power-on / reset node / reset communication;
    - :meth:`on_boot` -- boot-up sent, PRE-OPERATIONAL entered;
    - ``_model_step(dt, sync)`` -- advance the device model (wrapped by bench/tracking.py);
    - :meth:`supervise` -- the device's own periodic checks;
    - :meth:`on_heartbeat_lost` / :meth:`on_heartbeat_recovered` -- heartbeat consumer events;
    - :meth:`on_life_guarding_lost` / :meth:`on_life_guarding_recovered` -- life guarding events;
    - :meth:`answers_guarding` -- whether guarding RTRs are answered now;
    - :meth:`life_time_limit` -- the device's ceiling of the node life time;
    - :meth:`expedited_download` -- the data an expedited SDO download carries;
    - :meth:`refuse_sdo_request` -- SDO requests the device answers with an abort unserved
      (e.g. segmented or block transfers of a device with expedited transfer only).

    and acts by itself through :meth:`set_nmt_state`, :meth:`restart` and
    :meth:`reload_communication_objects`.
    """

    OPTIONS: dict[str, OptionSpec] = SLAVE_OPTIONS
    PDO_ENGINE: type[PdoEngine] = PdoEngine  # device models may bring their own PDO rules
    EMCY_PRODUCER: type[EmcyProducer] = EmcyProducer  # ... and their own EMCY frame layout
    NMT_COMMANDS: frozenset[NmtCommand] = frozenset(NmtCommand)  # ... and obey fewer NMT commands

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        self.node = node
        self.node_id = node.node_id
        self.name = node.name
        self.options = resolve_options(self.OPTIONS, options, node.name, axes=self._axis_count(node))
        self._lock = threading.RLock()
        self.store = ObjectStore(node.od)
        if key(IDENTITY, 4) in self.store:
            self.store.set_default(IDENTITY, 4, self.options['serial_number'])
        self._identity_from_device_info()
        if not self.options['heartbeat']:  # a node supervised by node guarding only
            self.store.remove(CONSUMER_HEARTBEAT)
            self.store.remove(PRODUCER_HEARTBEAT)
        add_guarding_objects(self.store)
        self._guarding = NodeGuarding(self.store, limit=self.life_time_limit)
        self._rtr_notifier: can.Notifier | None = None  # the Notifier whose RTR frames reach this node
        self._sdo_request: bytes | None = None  # the SDO request frame being served
        self.faults = CommFaults(boot_delay=self.options['boot_delay'], sdo_delay=self.options['sdo_delay'])
        self.frames_sent = 0  # frames this node put on the bus (for frame-loss checks)
        self._timers = TimerThread(f'sim-{node.name}')
        self._local = SimLocalNode(node.node_id, node.od, self._sdo_read, self._sdo_write, self._sdo_respond)
        self._network: canopen.Network | None = None
        self._owns_network = False
        self._subscriptions: list[tuple[int, Callback]] = []
        self._nmt = NmtState.OFF
        self._validators: dict[int, Callable[[Any], None]] = {}
        self._effects: dict[int, Callable[[Any], None]] = {}
        self._early: set[int] = set()
        self.emcy = self.EMCY_PRODUCER(self.store, self._send_emcy)
        self.pdo = self.PDO_ENGINE(self.store, lock=self._lock, timers=self._timers, send=self.send,
                             write_many=self._write_many,
                             subscribe=self._subscribe, unsubscribe=self._unsubscribe,
                             rpdo_allowed=self._rpdo_allowed, tpdo_allowed=self._tpdo_allowed,
                             emcy=lambda code: self.emcy.error(code, 'pdo', transient=True))
        self._consumer = HeartbeatConsumer()
        self._consumer_cobs: list[int] = []
        self._sync_cob: int | None = None
        self._heartbeat = Periodic(self._timers, self._send_heartbeat)
        self._tick = Periodic(self._timers, self._on_tick)
        self._boot_handle: TimerHandle | None = None
        self.received_sync_count = 0
        self.sync_cost = SyncCost()
        self._prev_sync_stamp: float | None = None
        self.sync_period = 0.0  # s, measured (moving average of SYNC intervals)
        self._last_sync = -math.inf
        self._last_advance = time.monotonic()
        self._register_communication_objects()

    def _identity_from_device_info(self) -> None:
        """0x1018 vendor id, product code and revision from the EDS's [DeviceInfo] where the
        file gives the objects no value (maxon's EPOS4 EDS): a device answers its identity."""
        info = self.node.od.device_information
        for sub, value in ((1, info.vendor_number), (2, info.product_number), (3, info.revision_number)):
            var = self.store.variables.get(key(IDENTITY, sub))
            if var is not None and var.value is None and var.default is None and value:
                self.store.set_default(IDENTITY, sub, int(value))

    @staticmethod
    def _axis_count(node: NodeConfig) -> int:
        return 1

    # ---- inspection ------------------------------------------------------------------
    @property
    def nmt_state(self) -> str:
        """'OFF', 'INITIALISING', 'PRE-OPERATIONAL', 'OPERATIONAL' or 'STOPPED'."""
        return self._nmt.label

    @property
    def powered(self) -> bool:
        return self._nmt is not NmtState.OFF

    @property
    def lock(self) -> threading.RLock:
        """The slave's lock: device models and tests hold it to see a consistent state."""
        return self._lock

    @property
    def error_register(self) -> int:
        with self._lock:
            return self.emcy.register

    @property
    def error_history(self) -> list[int]:
        """0x1003 entries, newest first."""
        with self._lock:
            count = self.store.values[key(ERROR_HISTORY, 0)]
            return [self.store.values[key(ERROR_HISTORY, s)] for s in range(1, count + 1)]

    def value(self, index: int, subindex: int = 0) -> Any:
        """The present value of an object, as SDO would read it (for tests)."""
        with self._lock:
            return self.store.get(key(index, subindex))

    # ---- bus attachment --------------------------------------------------------------
    def attach(self, network: canopen.Network) -> None:
        """Join ``network`` (shared with other simulated nodes; connected or not yet)."""
        with self._lock:
            if self._network is not None:
                raise RuntimeError(f'simulated node {self.name!r} is already on a network')
            self._network = network
            network[self.node_id] = self._local
            self._subscribe(NMT_COB_ID, self._on_nmt)
            self._subscribe(0x600 + self.node_id, self._on_sdo_request)
            self._update_sync_subscription()
            self._update_consumer()
            self._listen_for_guarding()

    def detach(self) -> None:
        with self._lock:
            if self._network is None:
                return
            self._stop_listening_for_guarding()
            for cob, callback in list(self._subscriptions):
                self._unsubscribe(cob, callback)
            self.pdo.close()
            self._sync_cob, self._consumer_cobs = None, []
            if self._network.nodes.get(self.node_id) is self._local:
                del self._network[self.node_id]
            self._network = None

    def connect(self, channel: Any, **bus_options: Any) -> SimulatedSlave:
        """Attach to a Network of its own on a ``virtual`` bus ``channel``."""
        network = canopen.Network()
        network.NOTIFIER_CYCLE = NOTIFIER_CYCLE
        network.connect(interface='virtual', channel=channel, receive_own_messages=False, **bus_options)
        try:
            self.attach(network)
        except Exception:
            network.disconnect()
            raise
        self._owns_network = True
        return self

    def close(self) -> None:
        """Power off, leave the bus, disconnect an owned Network. Idempotent."""
        self.power_off()
        network, owned = self._network, self._owns_network
        self.detach()
        self._owns_network = False
        if owned and network is not None:
            network.disconnect()

    def __enter__(self) -> SimulatedSlave:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _subscribe(self, cob: int, callback: Callback) -> None:
        if self._network is not None:
            self._network.subscribe(cob, callback)
            self._subscriptions.append((cob, callback))

    def _unsubscribe(self, cob: int, callback: Callback) -> None:
        if (cob, callback) in self._subscriptions:
            self._subscriptions.remove((cob, callback))
            if self._network is not None:
                try:
                    self._network.unsubscribe(cob, callback)
                except (KeyError, ValueError):
                    pass

    # ---- power and NMT ---------------------------------------------------------------
    def power_on(self) -> None:
        """INITIALISING, then (after the boot delay) boot-up frame and PRE-OPERATIONAL."""
        with self._lock:
            if self._network is None:
                raise RuntimeError(f'simulated node {self.name!r}: attach() or connect() before power_on()')
            if self._nmt is not NmtState.OFF:
                return
            self._listen_for_guarding()  # the Network may have been connected after attach()
            self._timers.start()
            self.store.reset()
            self.emcy.reset()
            self.reset_application()
            self._enter_initialising()
            self._last_advance = time.monotonic()
            self._tick.start(TICK_PERIOD)

    def power_off(self) -> None:
        """Silent at once: nothing sent or answered until the next power_on()."""
        with self._lock:
            if self._nmt is NmtState.OFF:
                return
            self.pdo.leave_operational()
            self.pdo.close()
            self._nmt = NmtState.OFF
            self._heartbeat.stop()
            self._tick.stop()
            if self._boot_handle is not None:
                self._boot_handle.cancel()
        self._timers.stop()

    def _enter_initialising(self) -> None:
        if self._nmt is NmtState.OPERATIONAL:
            self.pdo.leave_operational()
        self._nmt = NmtState.INITIALISING
        if self._guarding.lost:  # life guarding starts again: its event is over (no frame while initialising)
            self.on_life_guarding_recovered()
        self._guarding.reset()
        self.on_reset_communication()
        self._heartbeat.stop()
        if self._boot_handle is not None:
            self._boot_handle.cancel()
        self._boot_handle = self._timers.call_later(self.faults.boot_delay, self._boot)

    def _boot(self) -> None:
        with self._lock:
            if self._nmt is not NmtState.INITIALISING:
                return
            self._boot_handle = None
            self.pdo.rebuild()
            self._update_sync_subscription()
            self._update_consumer()
            self.announce_bootup()
            self._nmt = NmtState.PRE_OPERATIONAL
            self._restart_heartbeat()
            self.on_boot()

    def _reset(self, application: bool) -> None:
        """NMT reset node (application=True) or reset communication."""
        if application:
            self.store.reset()
            self.emcy.reset()
            self.reset_application()
        else:
            self.store.reset(0x1000, 0x1FFF)
        self._enter_initialising()

    def _on_nmt(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self._lock:
            if self.faults.muted or self._nmt in (NmtState.OFF, NmtState.INITIALISING):
                return
            command = addressed_command(bytes(data), self.node_id)
            if command is None or command not in self.NMT_COMMANDS:
                return
            if command is NmtCommand.START:
                self.set_nmt_state(NmtState.OPERATIONAL)
            elif command in (NmtCommand.STOP, NmtCommand.ENTER_PRE_OPERATIONAL):
                self.set_nmt_state(NmtState.STOPPED if command is NmtCommand.STOP else NmtState.PRE_OPERATIONAL)
            elif command is NmtCommand.RESET_NODE:
                self._reset(application=True)
            elif command is NmtCommand.RESET_COMMUNICATION:
                self._reset(application=False)

    def set_nmt_state(self, state: NmtState) -> None:
        """Enter OPERATIONAL, STOPPED or PRE-OPERATIONAL as on the NMT command (PDOs start or
        stop); also for a device that changes state by itself after boot-up or as an error
        reaction. Ignored while powered off or initialising."""
        with self._lock:
            if self._nmt in (NmtState.OFF, NmtState.INITIALISING) or state == self._nmt:
                return
            if state not in (NmtState.OPERATIONAL, NmtState.STOPPED, NmtState.PRE_OPERATIONAL):
                raise ValueError(f'{self.name}: {state!r} is not a state a node enters by command')
            if self._nmt is NmtState.OPERATIONAL:
                self.pdo.leave_operational()
            self._nmt = state
            if state is NmtState.OPERATIONAL:
                self.pdo.enter_operational()

    def restart(self, application: bool = True) -> None:
        """The device restarts by itself (e.g. a controller reboot after a configuration
        change): as NMT reset node (``application``) or reset communication, boot-up frame
        included. Ignored while powered off."""
        with self._lock:
            if self._nmt is not NmtState.OFF:
                self._reset(application)

    def reload_communication_objects(self) -> None:
        """Communication objects were replaced wholesale (a device's restore of defaults that
        takes effect at once): PDOs, SYNC subscription, heartbeat producer and consumer follow."""
        with self._lock:
            self.pdo.rebuild()
            self._update_sync_subscription()
            self._update_consumer()
            self._restart_heartbeat()

    def _rpdo_allowed(self) -> bool:
        return self._nmt is NmtState.OPERATIONAL and not self.faults.muted and not self.faults.drop_rpdos

    def _tpdo_allowed(self) -> bool:
        return self._nmt is NmtState.OPERATIONAL and not self.faults.muted and not self.faults.tpdos_stopped

    # ---- sending ---------------------------------------------------------------------
    def send(self, cob: int, data: bytes) -> None:
        """Send a frame as this node (nothing while powered off or muted)."""
        network = self._network
        if self.faults.muted or self._nmt is NmtState.OFF or network is None or network.bus is None:
            return
        try:
            network.send_message(cob, data)
            self.frames_sent += 1
        except Exception as exc:  # bus shut down under us while stopping
            logger.debug('%s: send 0x%03X failed: %s', self.name, cob, exc)

    def _send_emcy(self, cob: int, data: bytes) -> None:
        if self._nmt in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):  # CiA 301: no EMCY when STOPPED
            self.send(cob, data)

    # ---- heartbeat producer and consumer ---------------------------------------------
    def _restart_heartbeat(self) -> None:
        period_ms = self.store.values.get(key(PRODUCER_HEARTBEAT, 0), 0)
        if period_ms and self._nmt not in (NmtState.OFF, NmtState.INITIALISING):
            self._heartbeat.start(period_ms / 1000.0)
        else:
            self._heartbeat.stop()

    def _send_heartbeat(self) -> None:
        with self._lock:
            if self._nmt in (NmtState.OFF, NmtState.INITIALISING) or self.faults.heartbeat_stopped:
                return
            self.send(HEARTBEAT_BASE + self.node_id, bytes([int(self._nmt)]))

    def _update_consumer(self) -> None:
        entries = {k & 0xFF: v for k in self.store.keys_between(CONSUMER_HEARTBEAT, CONSUMER_HEARTBEAT)
                   if k & 0xFF and isinstance(v := self.store.values[k], int)}
        self._consumer.configure(entries)
        cobs = [HEARTBEAT_BASE + node for node in self._consumer.producers]
        for cob in self._consumer_cobs:
            if cob not in cobs:
                self._unsubscribe(cob, self._on_heartbeat)
        for cob in cobs:
            if cob not in self._consumer_cobs:
                self._subscribe(cob, self._on_heartbeat)
        self._consumer_cobs = cobs

    def _on_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self._lock:
            if self.faults.muted or self._nmt in (NmtState.OFF, NmtState.INITIALISING):
                return
            node = can_id - HEARTBEAT_BASE
            if self._consumer.heartbeat(node, time.monotonic()) and not self._consumer.is_lost():
                self.on_heartbeat_recovered(node)

    def on_heartbeat_lost(self, node: int) -> None:
        """Hook: the heartbeat of producer ``node`` (the master) timed out. Default: EMCY
        0x8130 with the node in byte 3; drives add their fault reaction."""
        self.emcy.error(EMCY_HEARTBEAT, 'heartbeat', manufacturer=bytes([node]))

    def on_heartbeat_recovered(self, node: int) -> None:
        """Hook: a lost producer's heartbeat is back. Default: its error is gone (EMCY 0x0000
        when no other error is left)."""
        self.emcy.clear('heartbeat')

    @property
    def heartbeat_lost(self) -> bool:
        with self._lock:
            return self._consumer.is_lost()

    # ---- node guarding and life guarding -----------------------------------------------
    def _listen_for_guarding(self) -> None:
        network = self._network
        notifier = getattr(network, 'notifier', None)
        if notifier is None or notifier is self._rtr_notifier:
            return
        self._stop_listening_for_guarding()
        RemoteFrames.of(notifier).add(HEARTBEAT_BASE + self.node_id, self._on_guarding_request)
        self._rtr_notifier = notifier

    def _stop_listening_for_guarding(self) -> None:
        notifier, self._rtr_notifier = self._rtr_notifier, None
        if notifier is not None:
            RemoteFrames.of(notifier).remove(HEARTBEAT_BASE + self.node_id)

    def _on_guarding_request(self, msg: can.Message) -> None:
        """Notifier thread: an RTR on 0x700 + node. Answered in every booted NMT state."""
        try:
            with self._lock:
                if self.faults.muted or self._nmt in (NmtState.OFF, NmtState.INITIALISING):
                    return
                if not self.answers_guarding():
                    return
                if not self.faults.guarding_silent:
                    reply = self._guarding.reply(int(self._nmt), self.faults.guarding_toggle_repeated)
                    self.send(HEARTBEAT_BASE + self.node_id, reply)
                if self._guarding.request(time.monotonic()):
                    self.on_life_guarding_recovered()
        except Exception:  # never let an exception stop the shared Notifier
            logger.exception('%s: node guarding reply failed', self.name)

    def on_life_guarding_lost(self) -> None:
        """Hook: no guarding RTR for the life time 0x100C x 0x100D (life guarding armed).
        Default after the option ``life_guarding_reaction``: 'emcy' sends EMCY 0x8130 (error
        register bit 4 until the RTRs resume), 'none' does nothing."""
        if self.options['life_guarding_reaction'] != 'none':
            self.emcy.error(EMCY_LIFE_GUARD, 'guarding')

    def on_life_guarding_recovered(self) -> None:
        """Hook: RTRs arrive again after a life guarding event, or a reset ends it. Default:
        its error is gone."""
        self.emcy.clear('guarding')

    def answers_guarding(self) -> bool:
        """Hook: whether guarding RTRs are answered (and feed life guarding) now. Default: always
        (a device that uses heartbeat instead while 0x1017 != 0 says no then)."""
        return True

    def life_time_limit(self) -> float:
        """Hook: s, the longest node life time the device supports (0x100C x 0x100D is clamped
        to it). Default: no limit."""
        return math.inf

    def remote_frames(self) -> RemoteFrames | None:
        """The RTR dispatcher of the bus Notifier this node listens on (None before its Network
        is connected): device models answering RTRs on other COB-IDs (RTR-only TPDOs) add
        their handlers to it, with the lock taken in the handler."""
        notifier = getattr(self._network, 'notifier', None)
        return None if notifier is None else RemoteFrames.of(notifier)

    @property
    def guarding_lost(self) -> bool:
        """Life guarding event raised and no RTR since."""
        with self._lock:
            return self._guarding.lost

    @property
    def guard_replies(self) -> int:
        """Guarding replies sent since the last boot-up (power-on or NMT reset)."""
        with self._lock:
            return self._guarding.replies

    # ---- SYNC and the model clock ----------------------------------------------------
    def _update_sync_subscription(self) -> None:
        cob = self.store.values.get(key(COB_ID_SYNC, 0), 0x80) & 0x7FF
        if cob != self._sync_cob:
            if self._sync_cob is not None:
                self._unsubscribe(self._sync_cob, self._on_sync)
            self._subscribe(cob, self._on_sync)
            self._sync_cob = cob

    def _on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        start = time.perf_counter()
        with self._lock:
            if self.faults.muted or self._nmt not in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
                return
            self.received_sync_count += 1
            now = time.monotonic()
            if self._prev_sync_stamp is not None and now - self._last_sync < self._sync_silence():
                dt = timestamp - self._prev_sync_stamp  # frame stamps: the producer's timing, not ours
                self.sync_period = dt if not self.sync_period else 0.9 * self.sync_period + 0.1 * dt
            else:
                dt = now - self._last_advance
            self._prev_sync_stamp = timestamp
            self._last_sync = self._last_advance = now
            operational = self._nmt is NmtState.OPERATIONAL
            if operational:
                self.pdo.apply_latched()
            self.pdo.open_window(timestamp)
            self._model_step(min(max(dt, 0.0), MAX_STEP), True)
            if operational:
                self.pdo.transmit_on_sync(data[0] if len(data) else None)
                self.pdo.poll_events()
            self.sync_cost.add(time.perf_counter() - start)

    def _sync_silence(self) -> float:
        """How long without SYNC before the drive's own clock takes over (3 cycles of 0x1006, >= 50 ms)."""
        return max(SYNC_SILENCE, 3e-6 * self.store.values.get(key(CYCLE_PERIOD, 0), 0))

    def cycle_period(self) -> float:
        """The SYNC cycle as the device knows it: 0x1006 if set, else measured, else 4 ms."""
        configured = self.store.values.get(key(CYCLE_PERIOD, 0), 0)
        if configured:
            return configured * 1e-6
        return self.sync_period or 0.004

    def _on_tick(self) -> None:
        with self._lock:
            if self._nmt is NmtState.OFF:
                return
            now = time.monotonic()
            booted = self._nmt is not NmtState.INITIALISING
            if booted:
                for node in self._consumer.expired(now):
                    self.on_heartbeat_lost(node)
            if now - self._last_sync >= self._sync_silence():
                dt, self._last_advance = now - self._last_advance, now
                self._model_step(min(max(dt, 0.0), MAX_STEP), False)
                self.pdo.poll_events()
            if booted:
                changed = self._guarding.expired(now)
                if changed:
                    self.on_life_guarding_lost()
                if self.supervise(now) or changed:
                    self.pdo.poll_events()

    # ---- device model hooks (subclasses) ---------------------------------------------
    def announce_bootup(self) -> None:
        """Hook: boot-up on the bus. Default (CiA 301): 0x700 + node with one byte 0x00."""
        self.send(HEARTBEAT_BASE + self.node_id, b'\x00')

    def reset_application(self) -> None:
        """Hook: power-on or NMT reset node, the device application starts again."""

    def on_reset_communication(self) -> None:
        """Hook: power-on, NMT reset node or reset communication: communication state starts again."""

    def on_boot(self) -> None:
        """Hook: boot-up sent, PRE-OPERATIONAL entered."""

    def _model_step(self, dt: float, sync: bool) -> None:
        """Hook: advance the device model by ``dt`` s; ``sync`` when triggered by a SYNC frame."""

    def supervise(self, now: float) -> bool:
        """Hook: the device's own periodic checks (every tick while booted, ``now`` monotonic);
        True when they changed what an event-driven TPDO may carry."""
        return False

    def expedited_download(self, index: int, subindex: int, data: bytes, request: bytes) -> bytes:
        """Hook: the data of an expedited SDO download (``request``: its frame) before the
        CiA 301 checks. A device that accepts other sizes than the object's fits them here."""
        return data

    def refuse_sdo_request(self, request: bytes) -> int | None:
        """Hook: the abort code with which the device answers the SDO request frame ``request``
        instead of serving it (the abort frame repeats the request's bytes 1..3). Default: None,
        every request is served (canopen's server: expedited, segmented, block)."""
        return None

    # ---- object access ---------------------------------------------------------------
    def register_object(self, index: int, subindex: int = 0, *, reader: Callable[[], Any] | None = None,
                        validator: Callable[[Any], None] | None = None,
                        on_write: Callable[[Any], None] | None = None, early: bool = False) -> None:
        """Make an object dynamic: ``reader`` serves reads, ``validator`` may raise
        SdoAbortedError to refuse a write, ``on_write`` applies it (after it is stored).
        ``early``: among values received in one go (RPDOs at a SYNC) its ``on_write``
        runs first (modes of operation before the controlword that relies on it)."""
        k = key(index, subindex)
        if k not in self.store:
            raise KeyError(f'{self.name}: 0x{index:04X}:{subindex:02X} is not in the object dictionary')
        if reader is not None:
            self.store.readers[k] = reader
        if validator is not None:
            self._validators[k] = validator
        if on_write is not None:
            self._effects[k] = on_write
            if early:
                self._early.add(k)

    def _store_value(self, k: int, value: Any) -> Callable[[Any], None] | None:
        """Check and store a written value; returns the reaction still to run (if any)."""
        index = k >> 8
        pdo_parameter = PDO_PARAMETERS[0] <= index <= PDO_PARAMETERS[1] and self.pdo.handles(index)
        if pdo_parameter:
            self.pdo.validate(index, k & 0xFF, value)
        validator = self._validators.get(k)
        if validator is not None:
            validator(value)
        self.store.values[k] = value
        if pdo_parameter:
            self.pdo.written(index)
        return self._effects.get(k)

    def _write(self, k: int, value: Any) -> None:
        """One value written by SDO: checked, stored, then acted upon."""
        effect = self._store_value(k, value)
        if effect is not None:
            effect(value)

    def _write_many(self, items: list[tuple[int, Any]]) -> None:
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

    def _check_injected_abort(self, index: int, subindex: int) -> None:
        code = self.faults.sdo_aborts.get((index, subindex))
        if code is not None:
            raise SdoAbortedError(code)

    def _sdo_read(self, index: int, subindex: int, check_readable: bool) -> bytes:
        with self._lock:
            self._check_injected_abort(index, subindex)
            return read_checked(self.store, index, subindex, check_readable)

    def _sdo_write(self, index: int, subindex: int, data: bytes, check_writable: bool) -> None:
        with self._lock:
            self._check_injected_abort(index, subindex)
            request = self._sdo_request
            if request is not None and expedited_download_of(request, index, subindex):
                data = self.expedited_download(index, subindex, bytes(data), request)
            self._write(key(index, subindex), decode_checked(self.store, index, subindex, data, check_writable))

    def _on_sdo_request(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self._lock:
            if self.faults.muted or self._nmt not in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
                return
            refused = self.refuse_sdo_request(bytes(data))
            if refused is not None:
                self._sdo_respond(bytes([0x80]) + bytes(data[1:4]) + refused.to_bytes(4, 'little'))
                return
            self._sdo_request = bytes(data)
            try:
                self._local.sdo.on_request(can_id, data, timestamp)
            finally:
                self._sdo_request = None
            self.pdo.poll_events()  # a write may have changed event-driven TPDO data

    def _sdo_respond(self, response: bytes) -> None:
        cob = 0x580 + self.node_id
        if self.faults.sdo_delay > 0:
            self._timers.call_later(self.faults.sdo_delay, lambda: self._send_locked(cob, response))
        else:
            self.send(cob, response)

    def _send_locked(self, cob: int, data: bytes) -> None:
        with self._lock:
            self.send(cob, data)

    # ---- CiA 301 communication objects -----------------------------------------------
    def _register_communication_objects(self) -> None:
        store = self.store
        if key(ERROR_REGISTER, 0) in store:
            self.register_object(ERROR_REGISTER, reader=lambda: self.emcy.register)
        if key(ERROR_HISTORY, 0) in store:
            self.register_object(ERROR_HISTORY, 0, validator=check_history_write,
                                 on_write=lambda value: self.emcy.clear_history())
        if key(COB_ID_SYNC, 0) in store:
            self.register_object(COB_ID_SYNC, validator=check_sync_cob,
                                 on_write=lambda value: self._update_sync_subscription())
        if key(COB_ID_EMCY, 0) in store:
            self.register_object(COB_ID_EMCY, validator=lambda value: check_emcy_cob(
                self.store.values[key(COB_ID_EMCY, 0)], value))
        if key(PRODUCER_HEARTBEAT, 0) in store:
            self.register_object(PRODUCER_HEARTBEAT, on_write=lambda value: self._restart_heartbeat())
        for k in list(store.keys_between(CONSUMER_HEARTBEAT, CONSUMER_HEARTBEAT)):
            sub = k & 0xFF
            if sub:
                def check(value: int, sub: int = sub) -> None:
                    check_consumer_write(self.store, sub, value)

                self.register_object(CONSUMER_HEARTBEAT, sub, validator=check,
                                     on_write=lambda value: self._update_consumer())
