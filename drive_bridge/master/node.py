"""One configured node at run time: its canopen RemoteNode, SDO channel, process data,
NMT/liveness bookkeeping and EMCY history. Its drive family decodes its EMCYs, says how its
boot-up shows and how it is supervised."""
from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import canopen

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia301.nmt import NmtState
from drive_bridge.families import BootDetection, Liveness, get_family
from drive_bridge.master.flood import EMCY_BURST, EMCY_RATE, TokenBucket
from drive_bridge.master.freshness import PdoFreshness
from drive_bridge.master.guarding import NodeGuard
from drive_bridge.master.pdo import ObjectKey, ProcessImage, od_variable
from drive_bridge.master.sdo import SdoChannel
from drive_bridge.master.sdo_worker import SdoWorker
from drive_bridge.model import MasterConfig, NodeConfig

if TYPE_CHECKING:
    from drive_bridge.master.errors import BootError

EMCY_HISTORY = 32


class BootState(str, Enum):
    """Where the master is with a node."""

    WAITING = 'waiting'  # not booted yet
    BOOTING = 'booting'
    OPERATIONAL = 'operational'  # configured and started
    FAILED = 'failed'  # boot failed; retried periodically
    LOST = 'lost'  # heartbeat or guarding lost after it was operational
    STALE = 'stale'  # alive (heartbeat) but a cyclic TPDO stopped: inputs untrusted, axes held


@dataclass(frozen=True)
class NodeSnapshot:
    """Immutable view of a node for the ROS layer and diagnostics."""

    name: str
    node_id: int
    family: str
    boot_state: BootState
    nmt_state: NmtState
    available: bool
    heartbeat_age: float | None  # seconds since the last heartbeat / guarding reply, None if never seen
    boot_attempts: int
    boot_error: str
    sdo_errors: int
    last_sdo_error: str
    pdo_errors: int
    last_pdo_error: str
    emcy: tuple[EmcyEvent, ...]  # newest last
    liveness: str = 'heartbeat'  # heartbeat, node guarding or none
    guarding_toggle_errors: int = 0  # repeated toggle bits seen (node guarding)
    emcy_suppressed: int = 0  # EMCYs over the rate limit: kept in the history, not reported


class NodeRuntime:
    """Everything the master tracks about one node; thread-safe snapshot()."""

    def __init__(self, network: canopen.Network, config: NodeConfig, master: MasterConfig,
                 on_emcy: Callable[[EmcyEvent, bool], None], on_error: Callable[[str], None]) -> None:
        self.config = config
        self.family = get_family(config.family)  # the description, one object per family
        self.family_node = self.family.node(config)  # what the family learns of this node
        self.network = network
        self.remote = canopen.RemoteNode(config.node_id, config.od)
        network.add_node(self.remote)
        self.liveness = self.family.liveness(config)
        self.sdo = SdoChannel(self.remote, config.timeouts.sdo, config.timeouts.sdo_retries)
        self.process = ProcessImage(config.od, config.rpdo, config.tpdo, self.family.sent_on_write)
        for cob_id in self.process.rx_layouts:
            network.subscribe(cob_id, self.process.on_tpdo)
        self.freshness = PdoFreshness(self.process.rx_layouts, self.process.rx_counts, master.sync_period)
        self.sync_count: Callable[[], int] = lambda: 0  # SYNCs sent so far (the master sets it)
        # a joint driver refused a set-point (joint, text); the master reports it as an event
        self.on_setpoint_refused: Callable[[str, str], None] = lambda _joint, _text: None
        self.worker = SdoWorker(self.sdo, lambda key, value, stamp: self.process.store(((key, value),), stamp),
                                on_error=on_error)
        for key in config.polled:  # inputs no TPDO carries: read by SDO, off the cycle thread
            self.worker.poll(key)
        # node guarding: polled by the supervisor once the boot configured it
        self.guard = NodeGuard.from_config(config) if self.liveness is Liveness.GUARDING else None
        self.guard_active = False
        self.heartbeat_timeout = (config.heartbeat_producer_ms * master.heartbeat_multiplier / 1000.0
                                  if self.liveness is Liveness.HEARTBEAT and master.heartbeat_consumer else 0.0)
        self.boot_state = BootState.WAITING
        self.boot_attempts = 0
        self.boot_error = ''
        self.next_boot_time = 0.0
        self.boot_refusal: BootError | None = None  # the last boot's refusal, kept across rounds
        self.nmt_state = NmtState.UNKNOWN
        self.last_heartbeat: float | None = None
        self.bootup_seen = threading.Event()
        # monotonic time of an ambiguous boot-up EMCY from a running node, until the node's
        # next reported NMT state confirms (not operational) or dismisses it
        self.bootup_suspected: float | None = None
        self._emcy: deque[EmcyEvent] = deque(maxlen=EMCY_HISTORY)
        self._on_emcy = on_emcy
        self._on_error = on_error
        self.emcy_limit = TokenBucket(EMCY_RATE, EMCY_BURST)
        self._state_listeners: list[Callable[[], None]] = []
        self.lock = threading.RLock()
        # subscribed last: a frame may arrive at once (a heartbeat during Master.start)
        # EMCY is decoded here (canopen's consumer drops frames shorter than 8 bytes)
        network.unsubscribe(0x80 + config.node_id, self.remote.emcy.on_emcy)
        network.subscribe(0x80 + config.node_id, self._on_emcy_frame)
        if self.liveness is Liveness.HEARTBEAT or self.family.boot.detection is BootDetection.BOOTUP_FRAME:
            self.remote.nmt.add_heartbeat_callback(self._on_heartbeat)

    @property
    def name(self) -> str:
        return self.config.name

    @property
    def node_id(self) -> int:
        return self.config.node_id

    @property
    def available(self) -> bool:
        """Process data can be trusted: booted, started, and its heartbeat is alive."""
        return self.boot_state is BootState.OPERATIONAL and self.nmt_state is NmtState.OPERATIONAL

    # events from the bus (Notifier thread) ---------------------------------------
    def _on_heartbeat(self, state: int) -> None:
        if state == 0:
            self.bootup_seen.set()
        if self.liveness is Liveness.HEARTBEAT:
            self.last_heartbeat = time.monotonic()
            self.nmt_state = NmtState.from_code(state)
            self._confirm_bootup(state, self.last_heartbeat)
        elif state == 0:  # a boot-up frame of a guarded node: it starts in pre-operational
            self.nmt_state = NmtState.PRE_OPERATIONAL
        self._notify()

    def attach_guard(self) -> None:
        if self.guard is not None:
            self.guard.attach(self.network)

    def restart_guarding(self) -> None:
        """Before a (re)boot: stop polling; the next reply's toggle is expected 0."""
        self.guard_active = False
        self.bootup_suspected = None
        if self.guard is not None:
            self.guard.reset()

    def on_guard_reply(self, state: int, age: float) -> None:
        """The latest node guarding reply (supervisor thread)."""
        self.last_heartbeat = time.monotonic() - age
        self.nmt_state = NmtState.from_code(state)
        if self._confirm_bootup(state, self.last_heartbeat):
            self._notify()

    def _confirm_bootup(self, state: int, at: float) -> bool:
        """An NMT state the node reported at ``at`` settles a suspected boot-up: not operational
        -> it rebooted (``bootup_seen``); True then."""
        suspected = self.bootup_suspected
        if suspected is None or at <= suspected:
            return False
        self.bootup_suspected = None
        if NmtState.from_code(state) is NmtState.OPERATIONAL:
            return False
        self.bootup_seen.set()
        return True

    def _on_emcy_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        payload = bytes(data)
        if self.family.boot.detection is BootDetection.EMCY and self.family.is_bootup_emcy(payload):
            if self.boot_state in (BootState.OPERATIONAL, BootState.LOST) and \
                    self.family.bootup_emcy_is_ambiguous(payload):
                self.bootup_suspected = time.monotonic()  # the next NMT state it reports tells
            else:
                self.bootup_seen.set()
                self.nmt_state = NmtState.PRE_OPERATIONAL
        event = self.family_node.decode_emcy(payload, timestamp)
        self._emcy.append(event)
        limit = self.emcy_limit
        reported = limit.allow(time.monotonic())
        self._on_emcy(event, reported)  # safety listeners get every EMCY, reporting ones the allowed
        if not reported and not limit.flooding:  # a babbling node: reported once per episode, then counted
            limit.flooding = True
            self._on_error(f'node {self.node_id} ({self.name}): EMCY flood, more than {EMCY_RATE:g}/s '
                           f'(latest 0x{event.code:04X} {event.text}); the excess is counted, not reported '
                           f'({limit.suppressed} so far)')
        self._notify()

    def add_state_listener(self, listener: Callable[[], None]) -> None:
        """Called on any heartbeat, EMCY or boot state change (from any thread)."""
        self._state_listeners = [*self._state_listeners, listener]

    def _notify(self) -> None:
        for listener in self._state_listeners:
            listener()

    def set_boot_state(self, state: BootState, error: str = '') -> None:
        with self.lock:
            if state is BootState.OPERATIONAL and self.boot_state is not BootState.OPERATIONAL:
                self.freshness.arm(time.monotonic(), self.sync_count())  # its TPDOs are due from now on
            self.boot_state = state
            self.boot_error = error
        self.worker.enabled = state is BootState.OPERATIONAL
        self._notify()

    # process data, mapped or not --------------------------------------------------
    def write(self, index: int, subindex: int, value: int | float) -> None:
        """Set an output: into its RPDO when mapped (sent by the cycle), else by SDO."""
        if self.process.has_output(index, subindex):
            self.process.set(index, subindex, value)
        else:
            self.worker.write((index, subindex), value)

    def read(self, index: int, subindex: int = 0) -> int | float | None:
        """Latest value of an input: from its TPDO when mapped, else polled by SDO."""
        value = self.process.get(index, subindex)
        if value is None and not self.process.has_input(index, subindex) and self.has_object(index, subindex):
            self.worker.poll((index, subindex))
        return value

    def has_object(self, index: int, subindex: int = 0) -> bool:
        return od_variable(self.config.od, index, subindex) is not None

    def sdo_read(self, index: int, subindex: int = 0) -> int | float | str | bytes:
        """Blocking typed SDO read (type from the EDS); SdoError on failure."""
        value = self.sdo.read(index, subindex)[1]
        return int(value) if isinstance(value, bool) else value

    def sdo_write(self, index: int, subindex: int, value: int | float) -> None:
        self.sdo.write(index, subindex, value)

    def sdo_read_raw(self, index: int, subindex: int = 0) -> bytes:
        """Blocking SDO read of the bytes as they are, never retried: parameter channels are
        streams, where a repeated request would skip or repeat data."""
        return self.sdo.upload(index, subindex, retry=False)

    def sdo_write_raw(self, index: int, subindex: int, data: bytes) -> None:
        """Blocking SDO write of bytes as they are, never retried (see sdo_read_raw)."""
        self.sdo.download(index, subindex, bytes(data), retry=False)

    def send_nmt(self, command: int) -> None:
        self.remote.nmt.send_command(command)

    def add_input_listener(self, listener: Callable[[frozenset[ObjectKey], float], None]) -> None:
        self.process.add_input_listener(listener)

    def report_setpoint_refused(self, joint: str, text: str) -> None:
        self.on_setpoint_refused(joint, text)

    def stamp(self, index: int, subindex: int = 0) -> float:
        return self.process.input_stamps.get((index, subindex), 0.0)

    def emcy_history(self) -> tuple[EmcyEvent, ...]:
        return tuple(self._emcy)

    def snapshot(self) -> NodeSnapshot:
        with self.lock:
            age = None if self.last_heartbeat is None else time.monotonic() - self.last_heartbeat
            return NodeSnapshot(
                name=self.name, node_id=self.node_id, family=self.config.family,
                boot_state=self.boot_state, nmt_state=self.nmt_state, available=self.available,
                heartbeat_age=age, boot_attempts=self.boot_attempts, boot_error=self.boot_error,
                sdo_errors=self.sdo.errors, last_sdo_error=self.sdo.last_error,
                pdo_errors=self.process.rx_errors, last_pdo_error=self.process.last_rx_error,
                emcy=tuple(self._emcy), liveness=self.liveness.value,
                guarding_toggle_errors=self.guard.status(time.monotonic()).toggle_errors if self.guard else 0,
                emcy_suppressed=self.emcy_limit.suppressed)

    def close(self) -> None:
        self.worker.stop()
        if self.guard is not None:
            self.guard.detach()
