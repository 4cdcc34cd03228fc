"""CiA 301 node guarding, master side, for nodes that have no heartbeat.

The master sends a remote frame (RTR) on COB-ID 0x700 + node id every guard time; the node
answers one byte: bit 7 a toggle (0 in the first reply after boot-up / reset communication,
alternating with each reply) and the NMT state in bits 0..6. The node is lost when no valid
reply came within the node life time (guard time x life time factor); a reply that repeats
the previous toggle is a guarding error and does not count as a sign of life.

canopen's NMT heartbeat callback masks the toggle bit, so :class:`NodeGuard` subscribes to the
raw COB-ID itself. Heartbeat and node guarding never run on one node.

Threads: :meth:`NodeGuard.poll` runs in the master's supervisor thread, replies arrive in
canopen's Notifier thread (:meth:`NodeGuard.on_response`); the state between them is under
one lock, and no lock is held while a frame is sent.
"""
from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import can
import canopen

from drive_bridge.model import NodeConfig

NMT_ERROR_CONTROL = 0x700  # COB-ID base of heartbeat, boot-up and node guarding
TOGGLE_BIT = 0x80
STATE_MASK = 0x7F
BOOTUP = 0x00  # the boot-up message: state 0, no toggle
GUARD_TIME = (0x100C, 0)  # U16, ms
LIFE_TIME_FACTOR = (0x100D, 0)  # U8
HEARTBEAT_PRODUCER = (0x1017, 0)  # U16, ms
OBJECT_ABSENT = (0x06020000, 0x06090011)  # SDO aborts: object / sub-index does not exist
MAX_PENDING = 32  # events kept between two polls
NMT_STATE_NAMES: dict[int, str] = {0: 'initialising', 4: 'stopped', 5: 'operational', 127: 'pre-operational'}

_NO_EVENTS: tuple[GuardEvent, ...] = ()


def nmt_state_name(state: int) -> str:
    return NMT_STATE_NAMES.get(state, f'unknown NMT state {state}')


class GuardEventKind(str, Enum):
    LOST = 'lost'  # no valid reply within the node life time
    TOGGLE_ERROR = 'toggle_error'  # a reply repeated the previous toggle bit
    BACK = 'back'  # a valid reply after LOST


@dataclass(frozen=True)
class GuardEvent:
    """A change of a guarded node's state, as :meth:`NodeGuard.poll` reports it."""

    kind: GuardEventKind
    node_id: int
    message: str  # 'node 5: ...'
    nmt_state: int | None  # from the last valid reply (bits 0..6); None before any
    age: float | None  # s since the last valid reply; None before any
    toggle_errors: int  # repeated toggles since attach / reset

    def __str__(self) -> str:
        return self.message


@dataclass(frozen=True)
class GuardStatus:
    """A guarded node at one moment (for snapshots and diagnostics)."""

    node_id: int
    active: bool  # attached or given send_rtr: poll sends RTRs
    lost: bool
    nmt_state: int | None
    age: float | None
    toggle_errors: int
    requests: int  # RTRs sent
    replies: int  # valid replies
    last_send_error: str


class NodeGuard:
    """Guards one node: :meth:`poll` sends the RTRs and reports :class:`GuardEvent` s.

    ``send_rtr`` sends the remote frame; without it :meth:`attach` sends through the
    network. ``clock`` is the time base of every ``now`` given to :meth:`poll` and of the
    reply times (default ``time.monotonic``, the supervisor's clock). Nothing is sent before
    the first :meth:`poll`, and nothing while detached (without ``send_rtr``).
    """

    def __init__(self, node_id: int, guard_time: float, life_time_factor: int,
                 send_rtr: Callable[[], None] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not 1 <= node_id <= 127:
            raise ValueError(f'node id must be 1..127, got {node_id}')
        if not guard_time > 0:
            raise ValueError(f'node {node_id}: guard time must be > 0 s, got {guard_time}')
        if not 1 <= life_time_factor <= 255:
            raise ValueError(f'node {node_id}: life time factor must be 1..255, got {life_time_factor}')
        self.node_id = node_id
        self.cob_id = NMT_ERROR_CONTROL + node_id
        self.guard_time = guard_time
        self.life_time_factor = life_time_factor
        self.life_time = guard_time * life_time_factor
        self._send_rtr = send_rtr
        self._clock = clock
        self._network: canopen.Network | None = None
        self._lock = threading.Lock()
        self._reset_locked()
        self._requests = 0
        self._replies = 0
        self._send_error = ''

    @classmethod
    def from_config(cls, config: NodeConfig, send_rtr: Callable[[], None] | None = None,
                    clock: Callable[[], float] = time.monotonic) -> NodeGuard:
        """The guard a node's ``guard_time_ms`` / ``life_time_factor`` ask for."""
        if not config.guarding:
            raise ValueError(f'node {config.node_id} ({config.name}) is not guarded (guard_time_ms is 0)')
        return cls(config.node_id, config.guard_time_ms / 1000.0, config.life_time_factor, send_rtr, clock)

    # -- wiring (any thread but the Notifier) ----------------------------------------------
    def attach(self, network: canopen.Network) -> None:
        """Receive the replies on 0x700 + node id (and send the RTRs, without ``send_rtr``)."""
        if self._network is network:
            return
        self.detach()
        network.subscribe(self.cob_id, self.on_response)
        self._network = network

    def detach(self) -> None:
        """Stop receiving replies (and, without ``send_rtr``, sending RTRs)."""
        network, self._network = self._network, None
        if network is not None:
            network.unsubscribe(self.cob_id, self.on_response)

    def reset(self) -> None:
        """The node was reset (boot-up / reset communication): expect toggle 0, forget the
        last reply, clear LOST and the toggle error count, and send the next RTR at the next poll.
        Call it before the node is reset, or while :meth:`poll` sends it no RTRs, so no
        reply to an earlier RTR is judged against the new expectation."""
        with self._lock:
            self._reset_locked()

    def _reset_locked(self) -> None:
        self._last_toggle: int | None = None  # of the last valid reply; None: expect 0
        self._last_reply: float | None = None
        self._nmt_state: int | None = None
        self._since: float | None = None  # first RTR after attach/reset: the life time's origin
        self._next_due: float | None = None
        self._lost = False
        self._toggle_errors = 0
        self._pending: deque[GuardEvent] = deque(maxlen=MAX_PENDING)  # bounded if nobody polls

    # -- replies (canopen's Notifier thread) -------------------------------------------------
    def on_response(self, can_id: int, data: bytes | bytearray, timestamp: float) -> None:
        """A frame on 0x700 + node id (canopen drops remote frames before this): a guarding
        reply, or a boot-up message, which restarts the toggle at 0. Both are one byte; other
        lengths are not CiA 301 error control frames and are ignored."""
        if len(data) != 1:
            return
        byte = data[0]
        now = self._clock()
        with self._lock:
            if byte == BOOTUP:
                self._last_toggle = None
                return
            toggle = 1 if byte & TOGGLE_BIT else 0
            expected = 0 if self._last_toggle is None else 1 - self._last_toggle
            if toggle != expected:
                self._toggle_errors += 1
                what = (f'toggle bit {toggle} repeated' if self._last_toggle is not None
                        else f'toggle bit {toggle} in the first reply after boot-up or reset')
                self._pending.append(self._event_locked(
                    GuardEventKind.TOGGLE_ERROR, now,
                    f'node guarding toggle error: {what}, expected {expected} '
                    f'({self._toggle_errors} toggle error(s) since reset); reply ignored'))
                return
            previous = self._last_reply
            self._last_toggle = toggle
            self._last_reply = now
            self._nmt_state = byte & STATE_MASK
            self._replies += 1
            if self._lost:
                self._lost = False
                silent = '' if previous is None else f' after {(now - previous) * 1000:.0f} ms without one'
                self._pending.append(self._event_locked(
                    GuardEventKind.BACK, now,
                    f'node guarding back: valid reply ({nmt_state_name(self._nmt_state)}){silent}'))

    def _event_locked(self, kind: GuardEventKind, now: float, text: str) -> GuardEvent:
        age = None if self._last_reply is None else now - self._last_reply
        return GuardEvent(kind, self.node_id, f'node {self.node_id}: {text}', self._nmt_state, age,
                          self._toggle_errors)

    # -- supervision (the master's supervisor thread) ----------------------------------------
    def poll(self, now: float) -> tuple[GuardEvent, ...]:
        """Send the RTR when due and return what changed since the last poll, oldest first.

        Cheap and non-blocking apart from the send itself. RTRs follow the guard time
        without drift; after a stalled poll one RTR goes out and the schedule restarts, so
        a late poll never sends a burst. Never raises: a failed send is kept for the LOST
        message (the missing replies then show it). Call it from one thread only."""
        send = self._send_rtr or (self._network_rtr if self._network is not None else None)
        if send is None:
            return _NO_EVENTS
        with self._lock:
            due = self._next_due is None or now >= self._next_due
            if due:
                self._since = now if self._since is None else self._since
                step = self._next_due + self.guard_time if self._next_due is not None else now + self.guard_time
                self._next_due = step if step > now else now + self.guard_time
            reference = self._last_reply if self._last_reply is not None else self._since
            if not self._lost and reference is not None and now - reference > self.life_time:
                self._lost = True
                self._pending.append(self._lost_event_locked(now, now - reference))
            events = tuple(self._pending) if self._pending else _NO_EVENTS
            self._pending.clear()
        if due:
            try:
                send()
            except Exception as exc:  # bus off, full queue: reported through LOST, never raised
                self._send_error = f'{type(exc).__name__}: {exc}'
            else:
                self._requests += 1
                self._send_error = ''
        return events

    def _lost_event_locked(self, now: float, age: float) -> GuardEvent:
        what = 'no valid reply' if self._last_reply is not None else 'no reply to any RTR'
        limit = (f'node life time {self.life_time * 1000:.0f} ms = guard time {self.guard_time * 1000:.0f} ms '
                 f'x life time factor {self.life_time_factor}')
        failed = f'; last RTR send failed: {self._send_error}' if self._send_error else ''
        return self._event_locked(GuardEventKind.LOST, now,
                                  f'node guarding lost: {what} for {age * 1000:.0f} ms ({limit}){failed}')

    def _network_rtr(self) -> None:
        """The RTR with DLC 1, the length of the reply it requests (as CANopenNode's master
        sends it; canopen's ``send_message(remote=True)`` can only give DLC 0), under the
        network's send lock like every other frame."""
        network = self._network
        if network is None or network.bus is None:
            raise RuntimeError('not connected to a CAN bus')
        frame = can.Message(arbitration_id=self.cob_id, is_extended_id=False, is_remote_frame=True, dlc=1)
        with network.send_lock:
            network.bus.send(frame)

    # -- state (any thread) -------------------------------------------------------------------
    @property
    def lost(self) -> bool:
        return self._lost

    @property
    def nmt_state(self) -> int | None:
        """NMT state (bits 0..6) of the last valid reply; None before any."""
        return self._nmt_state

    def age(self, now: float) -> float | None:
        """Seconds since the last valid reply; None before any."""
        last = self._last_reply
        return None if last is None else now - last

    def status(self, now: float) -> GuardStatus:
        with self._lock:
            return GuardStatus(
                node_id=self.node_id, active=self._send_rtr is not None or self._network is not None,
                lost=self._lost, nmt_state=self._nmt_state,
                age=None if self._last_reply is None else now - self._last_reply,
                toggle_errors=self._toggle_errors, requests=self._requests, replies=self._replies,
                last_send_error=self._send_error)


def configure_guarding(write: Callable[[int, int, int], object], has_object: Callable[[int, int], bool],
                       guard_time_ms: int, life_time_factor: int) -> None:
    """The boot step of a guarded node: heartbeat producer 0x1017 = 0 first (if the node has
    it; many drives drop guarding once a heartbeat time is set), then guard time 0x100C and
    life time factor 0x100D. SDO errors propagate for the caller to name the step, except
    "object does not exist" on 0x1017 (an EDS that lists it for a device without it: then
    there is no heartbeat to switch off)."""
    if not 1 <= guard_time_ms <= 0xFFFF:
        raise ValueError(f'guard time must be 1..65535 ms, got {guard_time_ms}')
    if not 1 <= life_time_factor <= 0xFF:
        raise ValueError(f'life time factor must be 1..255, got {life_time_factor}')
    if has_object(*HEARTBEAT_PRODUCER):
        try:
            write(*HEARTBEAT_PRODUCER, 0)
        except Exception as exc:
            if getattr(exc, 'abort_code', None) not in OBJECT_ABSENT:
                raise
    write(*GUARD_TIME, guard_time_ms)
    write(*LIFE_TIME_FACTOR, life_time_factor)
