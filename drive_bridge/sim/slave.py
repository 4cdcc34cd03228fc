"""A simulated CiA 301 slave: a real participant on a python-can ``virtual`` bus.

Composed, as canopen's LocalNode is of SdoServer, NmtSlave and EmcyProducer, of parts that
each serve one CiA 301 service and add what LocalNode lacks (ecosystem doc §1.1):

- :class:`~drive_bridge.sim.nmtslave.NmtSlave` -- NMT state, boot-up after resets received
  from the master, the NMT commands; the other parts ask it whether they may act;
- :class:`~drive_bridge.sim.sdoserver.SimSdoService` over
  :class:`~drive_bridge.sim.sdoserver.ObjectAccess` and the
  :class:`~drive_bridge.sim.store.ObjectStore` -- SDO with CiA 301 checks on writes
  (read-only, missing sub-indices, value limits, PDO parameter rules) and dynamic objects;
- :class:`~drive_bridge.sim.heartbeat.HeartbeatProducer` and
  :class:`~drive_bridge.sim.heartbeat.HeartbeatMonitor` (the consumer);
- :class:`~drive_bridge.sim.guardresponder.GuardingResponder` -- node and life guarding;
- :class:`~drive_bridge.sim.syncclock.SyncClock` -- SYNC, the model clock, the tick;
- the PDO engine and EMCY producer (with error history), chosen by the device model.

The slave wires them, owns the bus attachment and keeps the public API; the device model's
hooks, with their CiA 301 defaults, are in :mod:`~drive_bridge.sim.hooks`.

Threads: canopen's Notifier thread runs the frame callbacks, one :class:`TimerThread`
per slave runs everything timed. Both take the slave's lock (an RLock) and never
block while holding it (§1.4); delayed answers are scheduled, never slept.
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import Any

import canopen

from drive_bridge.model import NodeConfig
from drive_bridge.sim.commobjects import (
    COB_ID_SYNC,
    CONSUMER_HEARTBEAT,
    IDENTITY,
    PRODUCER_HEARTBEAT,
    check_consumer_write,
    check_emcy_cob,
    check_history_write,
    check_sync_cob,
)
from drive_bridge.sim.emcy import COB_ID_EMCY, ERROR_HISTORY, ERROR_REGISTER, EmcyProducer
from drive_bridge.sim.faults import CommFaultInjection, CommFaults
from drive_bridge.sim.guarding import NodeGuarding, RemoteFrames, add_guarding_objects
from drive_bridge.sim.guardresponder import GuardingResponder
from drive_bridge.sim.heartbeat import HeartbeatMonitor, HeartbeatProducer
from drive_bridge.sim.hooks import SlaveHooks
from drive_bridge.sim.nmt import NMT_COB_ID, NmtCommand, NmtState
from drive_bridge.sim.nmtslave import NmtSlave, Sequence
from drive_bridge.sim.nodebus import (
    NOTIFIER_CYCLE as NOTIFIER_CYCLE,  # where tests and sim.bus find it
    NodeBus,
    open_network,
)
from drive_bridge.sim.options import SLAVE_OPTIONS, OptionSpec, resolve_options
from drive_bridge.sim.pdo import PdoEngine
from drive_bridge.sim.sdoserver import ObjectAccess, SimSdoService
from drive_bridge.sim.store import ObjectStore, key
from drive_bridge.sim.syncclock import SyncClock
from drive_bridge.sim.synccost import SyncCost
from drive_bridge.sim.timers import TimerThread


class SimulatedSlave(CommFaultInjection, SlaveHooks):
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
    - ``model_step(dt, sync)`` -- advance the device model (wrapped by bench/tracking.py);
    - :meth:`supervise` -- the device's own periodic checks;
    - :meth:`on_heartbeat_lost` / :meth:`on_heartbeat_recovered` -- heartbeat consumer events;
    - :meth:`on_life_guarding_lost` / :meth:`on_life_guarding_recovered` -- life guarding events;
    - :meth:`answers_guarding` -- whether guarding RTRs are answered now;
    - :meth:`life_time_limit` -- the device's ceiling of the node life time;
    - :meth:`expedited_download` -- the data an expedited SDO download carries;
    - :meth:`refuse_sdo_request` -- SDO requests the device answers with an abort unserved
      (e.g. segmented or block transfers of a device with expedited transfer only).

    and acts by itself through :meth:`set_nmt_state`, :meth:`restart` and
    :meth:`reload_communication_objects`, on the slave's :attr:`timers` and :attr:`lock`.
    """

    OPTIONS: dict[str, OptionSpec] = SLAVE_OPTIONS
    PDO_ENGINE: type[PdoEngine] = PdoEngine  # device models may bring their own PDO rules
    EMCY_PRODUCER: type[EmcyProducer] = EmcyProducer  # ... and their own EMCY frame layout
    NMT_COMMANDS: frozenset[NmtCommand] = frozenset(NmtCommand)  # ... and obey fewer NMT commands

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        self.node = node
        self.node_id = node.node_id
        self.name = node.name
        self.options = resolve_options(self.OPTIONS, options, node.name, axes=self.axis_count(node))
        self._lock = threading.RLock()
        self.store = ObjectStore(node.od)
        if key(IDENTITY, 4) in self.store:
            self.store.set_default(IDENTITY, 4, self.options['serial_number'])
        self._identity_from_device_info()
        if not self.options['heartbeat']:  # a node supervised by node guarding only
            self.store.remove(CONSUMER_HEARTBEAT)
            self.store.remove(PRODUCER_HEARTBEAT)
        add_guarding_objects(self.store)
        self.faults = CommFaults(boot_delay=self.options['boot_delay'], sdo_delay=self.options['sdo_delay'])
        self._timers = TimerThread(f'sim-{node.name}')
        self.nmt: NmtSlave  # (made below)
        self.bus = NodeBus(node.name, self.faults, lambda: self.nmt.powered)
        # the parts, as canopen's LocalNode is composed of SdoServer, NmtSlave, EmcyProducer
        self.heartbeat: HeartbeatProducer  # (made below; the NMT slave's boot sequence uses them)
        self.guarding: GuardingResponder
        self.nmt = NmtSlave(self, self._timers, Sequence(
            reset_guarding=lambda: self.guarding.reset(), stop_heartbeat=lambda: self.heartbeat.stop(),
            load_communication=self._load_communication, restart_heartbeat=lambda: self.heartbeat.restart()))
        self.objects = ObjectAccess(self)
        self.sdo = SimSdoService(self, self.nmt, self._timers, self.objects)
        self.emcy = self.EMCY_PRODUCER(self.store, self._send_emcy)
        self.pdo = self.PDO_ENGINE(self.store, lock=self._lock, timers=self._timers, send=self.send,
                                   write_many=self.objects.write_many,
                                   subscribe=self.bus.subscribe, unsubscribe=self.bus.unsubscribe,
                                   rpdo_allowed=self._rpdo_allowed, tpdo_allowed=self._tpdo_allowed,
                                   emcy=lambda code: self.emcy.error(code, 'pdo', transient=True))
        self.heartbeat = HeartbeatProducer(self, self.nmt, self._timers)
        self.heartbeat_monitor = HeartbeatMonitor(self, self.nmt, self.bus.subscribe, self.bus.unsubscribe)
        self.guarding = GuardingResponder(self, self.nmt, NodeGuarding(self.store, limit=self.life_time_limit))
        self.sync_clock = SyncClock(self, self.nmt, self._timers, monitor=self.heartbeat_monitor,
                                    guarding=self.guarding, subscribe=self.bus.subscribe,
                                    unsubscribe=self.bus.unsubscribe)
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
    def axis_count(node: NodeConfig) -> int:
        """Hook: the axes ``node`` has (sizes the per-axis options); a CiA 301 node has one."""
        return 1

    # ---- inspection ------------------------------------------------------------------
    @property
    def nmt_state(self) -> str:
        """'OFF', 'INITIALISING', 'PRE-OPERATIONAL', 'OPERATIONAL' or 'STOPPED'."""
        return self.nmt.state.label

    @property
    def powered(self) -> bool:
        return self.nmt.powered

    @property
    def timers(self) -> TimerThread:
        """The slave's timer thread: a vendor simulator schedules its own delays on it."""
        return self._timers

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

    @property
    def received_sync_count(self) -> int:
        return self.sync_clock.received_count

    @property
    def sync_cost(self) -> SyncCost:
        return self.sync_clock.cost

    @property
    def sync_period(self) -> float:
        """s, measured (moving average of SYNC intervals)."""
        return self.sync_clock.period

    def cycle_period(self) -> float:
        """The SYNC cycle as the device knows it: 0x1006 if set, else measured, else 4 ms."""
        return self.sync_clock.cycle_period()

    @property
    def heartbeat_lost(self) -> bool:
        with self._lock:
            return self.heartbeat_monitor.lost

    @property
    def guarding_lost(self) -> bool:
        """Life guarding event raised and no RTR since."""
        with self._lock:
            return self.guarding.guarding.lost

    @property
    def guard_replies(self) -> int:
        """Guarding replies sent since the last boot-up (power-on or NMT reset)."""
        with self._lock:
            return self.guarding.guarding.replies

    def remote_frames(self) -> RemoteFrames | None:
        """The RTR dispatcher of the bus Notifier this node listens on (None before its Network
        is connected): device models answering RTRs on other COB-IDs (RTR-only TPDOs) add
        their handlers to it, with the lock taken in the handler."""
        return self.bus.remote_frames()

    @property
    def frames_sent(self) -> int:
        """Frames this node put on the bus (for frame-loss checks)."""
        return self.bus.frames_sent

    # ---- bus attachment --------------------------------------------------------------
    def attach(self, network: canopen.Network) -> None:
        """Join ``network`` (shared with other simulated nodes; connected or not yet)."""
        with self._lock:
            if self.bus.network is not None:
                raise RuntimeError(f'simulated node {self.name!r} is already on a network')
            self.bus.network = network
            network[self.node_id] = self.sdo.local
            self.bus.subscribe(NMT_COB_ID, self.nmt.on_command)
            self.bus.subscribe(0x600 + self.node_id, self.sdo.on_request)
            self.sync_clock.update_subscription()
            self.heartbeat_monitor.update()
            self.guarding.listen(self.bus.network)

    def detach(self) -> None:
        with self._lock:
            if self.bus.network is None:
                return
            self.guarding.stop_listening()
            self.bus.unsubscribe_all()
            self.pdo.close()
            self.sync_clock.forget()
            self.heartbeat_monitor.forget()
            if self.bus.network.nodes.get(self.node_id) is self.sdo.local:
                del self.bus.network[self.node_id]
            self.bus.network = None

    def connect(self, channel: Any, **bus_options: Any) -> SimulatedSlave:
        """Attach to a Network of its own on a ``virtual`` bus ``channel``."""
        network = open_network(channel, **bus_options)
        try:
            self.attach(network)
        except Exception:
            network.disconnect()
            raise
        self.bus.owned = True
        return self

    def close(self) -> None:
        """Power off, leave the bus, disconnect an owned Network. Idempotent."""
        self.power_off()
        network, owned = self.bus.network, self.bus.owned
        self.detach()
        self.bus.owned = False
        if owned and network is not None:
            network.disconnect()

    def __enter__(self) -> SimulatedSlave:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- power and NMT ---------------------------------------------------------------
    def power_on(self) -> None:
        """INITIALISING, then (after the boot delay) boot-up frame and PRE-OPERATIONAL."""
        with self._lock:
            if self.bus.network is None:
                raise RuntimeError(f'simulated node {self.name!r}: attach() or connect() before power_on()')
            if self.nmt.powered:
                return
            self.guarding.listen(self.bus.network)  # the Network may have been connected after attach()
            self._timers.start()
            self.nmt.power_on()
            self.sync_clock.start()

    def power_off(self) -> None:
        """Silent at once: nothing sent or answered until the next power_on()."""
        with self._lock:
            if not self.nmt.powered:
                return
            self.pdo.leave_operational()
            self.pdo.close()
            self.nmt.power_off()
            self.heartbeat.stop()
            self.sync_clock.stop()
        self._timers.stop()

    def _load_communication(self) -> None:
        """Boot-up: PDOs, SYNC subscription and heartbeat consumer as the store says."""
        self.pdo.rebuild()
        self.sync_clock.update_subscription()
        self.heartbeat_monitor.update()

    def set_nmt_state(self, state: NmtState) -> None:
        """Enter OPERATIONAL, STOPPED or PRE-OPERATIONAL as on the NMT command (PDOs start or
        stop); also for a device that changes state by itself after boot-up or as an error
        reaction. Ignored while powered off or initialising."""
        with self._lock:
            self.nmt.set_state(state)

    def restart(self, application: bool = True) -> None:
        """The device restarts by itself (e.g. a controller reboot after a configuration
        change): as NMT reset node (``application``) or reset communication, boot-up frame
        included. Ignored while powered off."""
        with self._lock:
            if self.nmt.powered:
                self.nmt.reset(application)

    def reload_communication_objects(self) -> None:
        """Communication objects were replaced wholesale (a device's restore of defaults that
        takes effect at once): PDOs, SYNC subscription, heartbeat producer and consumer follow."""
        with self._lock:
            self._load_communication()
            self.heartbeat.restart()

    def _rpdo_allowed(self) -> bool:
        return self.nmt.operational and not self.faults.muted and not self.faults.drop_rpdos

    def _tpdo_allowed(self) -> bool:
        return self.nmt.operational and not self.faults.muted and not self.faults.tpdos_stopped

    # ---- sending ---------------------------------------------------------------------
    def send(self, cob: int, data: bytes) -> None:
        """Send a frame as this node (nothing while powered off or muted)."""
        self.bus.send(cob, data)

    def _send_emcy(self, cob: int, data: bytes) -> None:
        if self.nmt.communicating:  # CiA 301: no EMCY when STOPPED
            self.send(cob, data)

    # ---- object access ---------------------------------------------------------------
    def register_object(self, index: int, subindex: int = 0, *, reader: Callable[[], Any] | None = None,
                        validator: Callable[[Any], None] | None = None,
                        on_write: Callable[[Any], None] | None = None, early: bool = False) -> None:
        """Make an object dynamic: ``reader`` serves reads, ``validator`` may raise
        SdoAbortedError to refuse a write, ``on_write`` applies it (after it is stored).
        ``early``: among values received in one go (RPDOs at a SYNC) its ``on_write``
        runs first (modes of operation before the controlword that relies on it)."""
        self.objects.register(index, subindex, reader=reader, validator=validator, on_write=on_write, early=early)

    def write_object(self, k: int, value: Any) -> None:
        """Write ``value`` to ``key(index, subindex)`` as an SDO download would: checked,
        stored, then acted upon (a device's own channel, e.g. an ASCII terminal)."""
        self.objects.write(k, value)

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
                                 on_write=lambda value: self.sync_clock.update_subscription())
        if key(COB_ID_EMCY, 0) in store:
            self.register_object(COB_ID_EMCY, validator=lambda value: check_emcy_cob(
                self.store.values[key(COB_ID_EMCY, 0)], value))
        if key(PRODUCER_HEARTBEAT, 0) in store:
            self.register_object(PRODUCER_HEARTBEAT, on_write=lambda value: self.heartbeat.restart())
        for k in list(store.keys_between(CONSUMER_HEARTBEAT, CONSUMER_HEARTBEAT)):
            sub = k & 0xFF
            if sub:
                def check(value: int, sub: int = sub) -> None:
                    check_consumer_write(self.store, sub, value)

                self.register_object(CONSUMER_HEARTBEAT, sub, validator=check,
                                     on_write=lambda value: self.heartbeat_monitor.update())
