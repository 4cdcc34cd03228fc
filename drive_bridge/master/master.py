"""The CANopen master of one bus: owns the bus, the canopen Network, the nodes and axes,
the cycle (SYNC and the set-points around it: master/cycle.py) and its supervision (boot,
retries, heartbeats: master/supervision.py), and serves SDO, NMT and parameters.

Threads: canopen's Notifier (frames in: TPDO, heartbeat, EMCY, SDO responses), the
cycle (SYNC, then the RPDOs for the next SYNC once the TPDOs are in), the supervisor
(heartbeat timeouts, boot scheduling) and one short-lived thread per node boot
(docs/architecture.md, Threads). Public methods are safe from any thread except the
Notifier (they may block on SDO).
"""
from __future__ import annotations

import functools
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import can
import canopen

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia301.nmt import NMT_COMMANDS
from drive_bridge.config.errors import ConfigError
from drive_bridge.families.errors import ParameterError
from drive_bridge.families.parameters import ParameterAccess
from drive_bridge.joint import AxisSnapshot, DriveState, JointDriver
from drive_bridge.master.boot import boot_node
from drive_bridge.master.bus import BusHealth, FrameListener, FrameTap, TappedBus, open_bus
from drive_bridge.master.busload import BusTraffic, TrafficCounter
from drive_bridge.master.cycle import Cycle
from drive_bridge.master.errors import ObjectAddress, SdoError
from drive_bridge.master.events import BusEvent, EventKind, Level
from drive_bridge.master.feedback import CycleFeedback
from drive_bridge.master.flood import UnknownFrames
from drive_bridge.master.kernelsync import KernelSync, require_kernel_periodic
from drive_bridge.master.node import NodeRuntime, NodeSnapshot
from drive_bridge.master.run_on import RunOnStop
from drive_bridge.master.sdo import AUTO, SdoChannel, SdoPlain
from drive_bridge.master.supervision import Supervisor
from drive_bridge.master.sync import SyncProducer, SyncStats
from drive_bridge.model import BusConfig

log = logging.getLogger('drive_bridge.master')

ADHOC_SDO_TIMEOUT = 0.3
LEAVES_OPERATIONAL = frozenset({0x02, 0x80, 0x81, 0x82})  # stop, pre-operational, the resets


@dataclass(frozen=True)
class BusSnapshot:
    """The whole bus at one moment: nodes, axes, SYNC timing."""

    nodes: tuple[NodeSnapshot, ...]
    axes: tuple[AxisSnapshot, ...]
    sync: SyncStats | None
    bus_state: str
    channel: str
    traffic: BusTraffic
    health: BusHealth | None = None  # receive/send errors and error frames (None: bus not open)


class Master:
    """Start with :meth:`start`, stop with :meth:`stop` (or use as a context manager)."""

    def __init__(self, config: BusConfig, bus: can.BusABC | None = None) -> None:
        self.config = config
        self._raw_bus = bus
        self.tap = FrameTap()
        self.traffic = TrafficCounter(config.bus.bitrate)
        self.tap.add_listener(self.traffic)
        self.bus: TappedBus | None = None
        self.network = canopen.Network()
        self.unknown_frames = UnknownFrames(self.network.subscribers)  # counted, reported by the supervisor
        self.tap.add_listener(self.unknown_frames)
        self.nodes: dict[str, NodeRuntime] = {}
        self.axes: dict[str, JointDriver] = {}
        self._by_id: dict[int, NodeRuntime] = {}
        self._adhoc: dict[int, SdoChannel] = {}
        self._adhoc_lock = threading.Lock()
        self._parameters: dict[int, ParameterAccess] = {}
        self._event_listeners: list[Callable[[BusEvent], None]] = []
        self._emcy_listeners: list[Callable[[EmcyEvent], None]] = []
        self._safety_emcy_listeners: list[Callable[[EmcyEvent], None]] = []
        self.feedback = CycleFeedback()
        self._heartbeat_task: canopen.network.PeriodicMessageTask | None = None
        self._stop = threading.Event()
        self._supervisor: threading.Thread | None = None
        self.events: list[BusEvent] = []  # recent events (bounded)
        self.started = False
        self.bus_reopens = 0
        self._run_on = RunOnStop(lambda node, level, text: self._emit(
            EventKind.RUN_ON_STOP, Level.ERROR if level == 'error' else Level.WARN, text, node))
        self.cycle = Cycle(config.master, self.network, nodes=self.nodes, axes=self.axes, feedback=self.feedback,
                           run_on=self._run_on, emit=self._emit,
                           bus=lambda: self.bus, bus_down=lambda: self.bus_down)
        self._supervision = Supervisor(
            nodes=self.nodes, axes=self.axes, channel=str(config.bus.channel), stop=self._stop, emit=self._emit,
            boot_node=self._boot_node, bus_health=lambda: self.bus.health() if self.bus is not None else None,
            reopen_bus=self._reopen_bus, on_bus_down=functools.partial(self.cycle.run_kernel_sync, False),
            on_bus_back=functools.partial(self.cycle.run_kernel_sync, True), sync_count=self.cycle.count,
            unknown_frames=self.unknown_frames.report, run_on=self._run_on)

    # -- listeners ---------------------------------------------------------------------------
    def add_frame_listener(self, listener: FrameListener) -> None:
        """Every frame, both directions (``msg.is_rx``); called in bus threads, keep it short."""
        self.tap.add_listener(listener)

    def add_event_listener(self, listener: Callable[[BusEvent], None]) -> None:
        self._event_listeners = [*self._event_listeners, listener]

    def add_emcy_listener(self, listener: Callable[[EmcyEvent], None], safety: bool = False) -> None:
        """Reporting listeners get the EMCYs within the per-node rate limit (a babbling node is
        counted, not reported); ``safety`` listeners (reactions such as aborting a stream on a
        buffer underflow) get every EMCY, also in a flood (Notifier thread, keep it short)."""
        if safety:
            self._safety_emcy_listeners = [*self._safety_emcy_listeners, listener]
        else:
            self._emcy_listeners = [*self._emcy_listeners, listener]

    def add_cycle_listener(self, listener: Callable[[int], None]) -> None:
        """Called after each cycle's SYNC and set-points (cycle thread, keep it short)."""
        self.cycle.add_listener(listener)

    def add_feedback_listener(self, listener: Callable[[], None]) -> None:
        """Called once per cycle when every available node's synchronous TPDOs answering the
        SYNC are in (CAN thread, keep it short); not in a cycle where one is missing."""
        self.feedback.add_listener(listener)

    def _emit(self, kind: EventKind, level: Level, message: str, node: NodeRuntime | None = None,
              joint: str = '') -> None:
        event = BusEvent(kind, level, message, node.node_id if node else 0, node.name if node else '', joint=joint)
        self.events = [*self.events[-199:], event]
        if not self._event_listeners:  # a listener reports events itself: print each line once
            getattr(log, {'info': 'info', 'warn': 'warning', 'error': 'error'}[level.value])(message)
        for listener in self._event_listeners:
            try:
                listener(event)
            except Exception as exc:  # a broken listener must not stop supervision
                log.error('event listener failed: %r', exc)

    def _on_emcy(self, event: EmcyEvent, reported: bool) -> None:
        """Every EMCY of a node (Notifier thread); ``reported``: within its rate limit."""
        listeners = [*self._safety_emcy_listeners, *self._emcy_listeners] if reported else self._safety_emcy_listeners
        for listener in listeners:
            try:
                listener(event)
            except Exception as exc:
                log.error('EMCY listener failed: %r', exc)

    def _setpoint_refused(self, node: NodeRuntime, joint: str, text: str) -> None:
        self._emit(EventKind.SETPOINT_REFUSED, Level.ERROR, text, node, joint)

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self) -> None:
        """Open the bus, start SYNC and heartbeat, and boot every node in the background.
        ConfigError when the bus cannot do what the configuration asks (nothing left running)."""
        if self.started:
            return
        cfg = self.config
        raw = self._raw_bus or open_bus(cfg.bus.interface, cfg.bus.channel, cfg.bus.bitrate, **dict(cfg.bus.options))
        self._check_capabilities(raw)
        self.bus = TappedBus(raw, self.tap, on_fault=lambda text: log.warning('%s', text))
        self.network.bus = self.bus
        self.network.connect()
        for node_cfg in cfg.nodes:
            node = NodeRuntime(self.network, node_cfg, cfg.master, self._on_emcy,
                               lambda text: self._emit(EventKind.ERROR, Level.WARN, text))
            self.nodes[node.name] = node
            self._by_id[node.node_id] = node
            if node_cfg.pdo_summary:
                self._emit(EventKind.CONFIGURED, Level.INFO,
                           f'node {node.node_id} ({node.name}): {node_cfg.pdo_summary}', node)
            node.attach_guard()
            node.sync_count = self.cycle.count
            node.on_setpoint_refused = functools.partial(self._setpoint_refused, node)
            for axis_cfg in node_cfg.axes:
                self.axes[axis_cfg.joint] = node.family_node.create_joint_driver(node, axis_cfg, node_cfg.timeouts,
                                                                                 cfg.master.cycle_period)
        self.feedback.watch(self.network, self.nodes.values())
        self.unknown_frames.active = True
        self.cycle.start()
        if cfg.master.heartbeat_producer_ms:
            self._heartbeat_task = self.network.send_periodic(
                0x700 + cfg.master.node_id, b'\x05', cfg.master.heartbeat_producer_ms / 1000.0)
        self.started = True
        self._stop.clear()
        self._supervisor = threading.Thread(target=self._supervision.run, name='drive_bridge-supervisor', daemon=True)
        self._supervisor.start()

    def _check_capabilities(self, raw: can.BusABC) -> None:
        """What the configuration needs of the interface, checked before anything runs on it."""
        cfg = self.config
        if cfg.master.sends_sync and cfg.master.sync_producer == 'kernel':
            try:
                require_kernel_periodic(raw, cfg.bus.interface, cfg.bus.channel,
                                        str(cfg.path) if cfg.path else 'bus configuration')
            except ConfigError:
                if self._raw_bus is None:  # the master's own interface; one passed in is the caller's
                    raw.shutdown()
                raise

    def stop(self, stop_timeout: float = 1.0) -> None:
        """Quick-stop enabled axes (bounded wait), then stop SYNC, heartbeat and the bus."""
        if not self.started:
            return
        self._stop_axes(list(self.axes.values()), stop_timeout)
        self._stop.set()
        if self._supervisor is not None:
            self._supervisor.join(timeout=2)
        self._supervision.join_boots(timeout=5)
        self.cycle.stop()
        if self._heartbeat_task is not None:
            self._heartbeat_task.stop()
        for node in self.nodes.values():
            node.close()
        self.network.disconnect()  # shuts the bus down, also one passed in by the caller
        self.started = False

    def __enter__(self) -> Master:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def sync(self) -> SyncProducer | None:
        """The master's SYNC producer (None when another node or the kernel produces SYNC)."""
        return self.cycle.sync

    @property
    def kernel_sync(self) -> KernelSync | None:
        """The kernel's periodic SYNC (``sync_producer: kernel``)."""
        return self.cycle.kernel_sync

    # -- supervision (master/supervision.py) ----------------------------------------------------
    def _boot_node(self, node: NodeRuntime) -> None:
        boot_node(node, self.config.master, log.debug)

    def _reopen_bus(self) -> bool:
        """Reopen an interface the master opened itself (False: the caller's, or none)."""
        if self._raw_bus is not None or self.bus is None:
            return False
        cfg = self.config.bus
        try:
            self.bus.replace_inner(open_bus(cfg.interface, cfg.channel, cfg.bitrate, **dict(cfg.options)))
        except can.CanError as exc:
            log.warning('reopening the bus failed: %s', exc)
            return True
        self.bus_reopens += 1
        log.warning('bus %s reopened (attempt %d)', cfg.channel, self.bus_reopens)
        return True

    @property
    def bus_down(self) -> bool:
        """The bus failed (bus-off, interface errors) and has not come back."""
        return self._supervision.bus_down

    def wait_until_operational(self, timeout: float, names: list[str] | None = None) -> None:
        """Block until the given nodes (default all) are operational; TimeoutError says which are not."""
        wanted = [self.nodes[n] for n in names] if names else list(self.nodes.values())
        deadline = time.monotonic() + timeout
        while True:
            pending = [n for n in wanted if not (n.available and all(
                self.axes[a.joint].ready for a in n.config.axes))]
            if not pending:
                return
            if time.monotonic() > deadline:
                details = '; '.join(f'node {n.node_id} ({n.name}): {n.boot_state.value}'
                                    + (f', {n.boot_error}' if n.boot_error else '') for n in pending)
                raise TimeoutError(f'nodes not operational after {timeout:.1f} s: {details}')
            time.sleep(0.01)

    # -- services ------------------------------------------------------------------------------
    def node_by_id(self, node_id: int) -> NodeRuntime | None:
        return self._by_id.get(node_id)

    def _channel(self, node_id: int) -> SdoChannel:
        if not 1 <= node_id <= 127:
            raise SdoError(ObjectAddress(node_id, 0, 0), 'node id must be 1..127')
        node = self._by_id.get(node_id)
        if node is not None:
            return node.sdo
        with self._adhoc_lock:  # a node on the bus that is not in the configuration
            if node_id not in self._adhoc:
                remote = canopen.RemoteNode(node_id, canopen.ObjectDictionary())
                self.network.add_node(remote)
                self._adhoc[node_id] = SdoChannel(remote, ADHOC_SDO_TIMEOUT, 0)
            return self._adhoc[node_id]

    def sdo_read(self, node_id: int, index: int, subindex: int,
                 data_type: int = AUTO) -> tuple[int, SdoPlain, bytes]:
        """(data type, value, raw bytes). Nodes outside the config need an explicit data type."""
        return self._channel(node_id).read(index, subindex, data_type)

    def sdo_write(self, node_id: int, index: int, subindex: int, value: SdoPlain,
                  data_type: int = AUTO) -> int:
        return self._channel(node_id).write(index, subindex, value, data_type)

    def nmt(self, command: int, node_id: int = 0, stop_timeout: float = 1.0) -> None:
        """Send an NMT command to one node or (0) all; ValueError for a bad command or id.
        A command that takes a node out of OPERATIONAL first quick-stops its enabled axes
        (bounded wait): a drive that runs on when the bus stops (no heartbeat consumer, no
        RPDO timeout) must not keep its last command."""
        if command not in NMT_COMMANDS:
            known = ', '.join(f'{c} ({n})' for c, n in NMT_COMMANDS.items())
            raise ValueError(f'unknown NMT command {command}; use one of {known}')
        if not 0 <= node_id <= 127:
            raise ValueError(f'NMT node id must be 0 (all) or 1..127, got {node_id}')
        if command in LEAVES_OPERATIONAL:
            self._stop_axes([a for a in self.axes.values() if node_id in (0, a.node_id)], stop_timeout)
        self.network.send_message(0x000, bytes([command, node_id]))

    def _stop_axes(self, axes: list[JointDriver], timeout: float) -> None:
        """Quick-stop the enabled ones; a failure is logged, never raised (stopping goes on)."""
        for axis in axes:
            if axis.drive_state is not DriveState.ENABLED:
                continue
            try:
                axis.quick_stop(timeout=timeout)
            except Exception as exc:
                log.warning('stopping %s: %s', axis.joint, exc)

    def parameter_access(self, node_id: int) -> ParameterAccess:
        """The family's access to the vendor parameters of a configured node (one per node,
        kept); ParameterError names an unknown node or a family that offers none."""
        node = self._by_id.get(node_id)
        if node is None:
            known = ', '.join(f'{n.node_id} ({n.name})' for n in self.nodes.values())
            raise ParameterError(f'node {node_id} is not in the bus configuration (configured: {known})',
                                 node_id=node_id)
        with self._adhoc_lock:
            access = self._parameters.get(node_id)
            if access is None:
                access = node.family_node.parameters(node)
                if access is None:
                    raise ParameterError(f'node {node_id} ({node.name}): drive family {node.family.name!r} '
                                         'offers no access to vendor parameters; use sdo_read/sdo_write',
                                         node_id=node_id)
                self._parameters[node_id] = access
        return access

    def snapshot(self) -> BusSnapshot:
        return BusSnapshot(
            nodes=tuple(node.snapshot() for node in self.nodes.values()),
            axes=tuple(axis.snapshot() for axis in self.axes.values()),
            sync=self.sync.stats() if self.sync is not None else None,
            bus_state=self.bus.state.name if self.bus is not None else 'CLOSED',
            channel=str(self.config.bus.channel), traffic=self.traffic.traffic(),
            health=self.bus.health() if self.bus is not None else None)


