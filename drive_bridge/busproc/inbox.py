"""What reaches the node process from its bus process, and who hears of it: the readers of
the three lanes (the cyclic state, the request lane's reports, the stop lane's answers) and the
listeners the ROS layer registers. :class:`~.client.BusClient` is an Inbox."""
from __future__ import annotations

import concurrent.futures
import logging
import threading
from collections.abc import Callable, Sequence
from typing import Any

import can

from drive_bridge.busproc import cyclic, wire
from drive_bridge.busproc.errors import BusProcessStartError
from drive_bridge.busproc.executor import ExecutorProxy
from drive_bridge.busproc.failures import exception
from drive_bridge.busproc.proxies import AxisProxy
from drive_bridge.busproc.reports import (
    AxisStates,
    CommandRefused,
    Failure,
    Farewell,
    Frames,
    HandleState,
    Ready,
    Reply,
    StartFailed,
    StopOutcome,
    unpack_frames,
)
from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.master.events import BusEvent
from drive_bridge.master.master import BusSnapshot

log = logging.getLogger('drive_bridge.busproc')

EVENTS_KEPT = 200


class Inbox:
    """The readers and the listeners; the client provides the lanes, the axes and the executor."""

    axes: dict[str, AxisProxy]
    joints: list[str]
    executor: ExecutorProxy
    stop_lane: wire.Lane
    request_lane: wire.Lane
    state_lane: wire.Lane

    def __init__(self) -> None:
        self.events: list[BusEvent] = []
        self.frame_drops = 0  # frames the bus process could not forward (its queue was full)
        self.state_drops = 0  # cyclic states it could not send (this process's buffer was full)
        self.report_drops = 0  # reports its full outbox dropped (events, EMCY, trajectory states, refusals)
        self._pending: dict[int, concurrent.futures.Future[object]] = {}
        self._pending_lock = threading.Lock()
        self._taken: dict[str, float] = {}  # joint -> when the applied snapshot was taken (bus process)
        self._taken_lock = threading.Lock()
        self._ready: concurrent.futures.Future[Ready] = concurrent.futures.Future()
        self._event_listeners: list[Callable[[BusEvent], None]] = []
        self._emcy_listeners: list[Callable[[EmcyEvent], None]] = []
        self._feedback_listeners: list[Callable[[], None]] = []
        self._frame_listeners: list[Callable[[can.Message], None]] = []
        self._lost_listeners: list[Callable[[str], None]] = []
        self._refusal_listeners: list[Callable[[str, str], None]] = []
        self.final: BusSnapshot | None = None  # the bus process's last snapshot, when it ended on request

    @property
    def frame_listeners(self) -> tuple[Callable[[can.Message], None], ...]:
        """Who wants the frames now (frames cross from the bus process while any does)."""
        return tuple(self._frame_listeners)

    def _lost(self, reason: str) -> None:
        raise NotImplementedError

    def settings(self, **changes: object) -> None:
        raise NotImplementedError

    # -- listeners -------------------------------------------------------------------------------------
    def add_event_listener(self, listener: Callable[[BusEvent], None]) -> None:
        self._event_listeners = [*self._event_listeners, listener]

    def add_emcy_listener(self, listener: Callable[[EmcyEvent], None]) -> None:
        """EMCYs within the bus process's per-node reporting limit."""
        self._emcy_listeners = [*self._emcy_listeners, listener]

    def add_feedback_listener(self, listener: Callable[[], None]) -> None:
        """Called with every cyclic state (the state lane's reader thread; keep it short)."""
        self._feedback_listeners = [*self._feedback_listeners, listener]

    def add_lost_listener(self, listener: Callable[[str], None]) -> None:
        self._lost_listeners = [*self._lost_listeners, listener]

    def add_refusal_listener(self, listener: Callable[[str, str], None]) -> None:
        """(topic, reason) of each direct command the bus process refused."""
        self._refusal_listeners = [*self._refusal_listeners, listener]

    def add_frame_listener(self, listener: Callable[[can.Message], None]) -> None:
        """Every frame, both directions, in batches from the bus process (forwarded only while
        some listener wants them)."""
        first = not self._frame_listeners
        self._frame_listeners = [*self._frame_listeners, listener]
        if first:
            self.settings(frames=True)

    def remove_frame_listener(self, listener: Callable[[can.Message], None]) -> None:
        self._frame_listeners = [f for f in self._frame_listeners if f is not listener]
        if not self._frame_listeners:
            self.settings(frames=False)

    # -- readers ---------------------------------------------------------------------------------------------
    def start_readers(self) -> list[threading.Thread]:
        """One daemon thread per lane (cyclic state, request-lane reports, stop answers), started."""
        threads = [threading.Thread(target=target, name=f'drive_bridge-client-{name}', daemon=True)
                   for target, name in ((self._read_state, 'state'), (self._read_requests, 'requests'),
                                        (self._read_stops, 'stops'))]
        for thread in threads:
            thread.start()
        return threads

    def _read_state(self) -> None:
        joints = len(self.joints)
        axes = [self.axes[j] for j in self.joints]
        while True:
            data = self.state_lane.recv_bytes()
            if data is None:
                self._lost('state lane closed')
                return
            try:
                state = cyclic.unpack(data, joints)
            except ValueError as exc:
                log.error('state lane: %s', exc)
                continue
            for axis, feedback in zip(axes, state.joints):
                axis.on_feedback(feedback)
            self.executor.lag, self.executor.stalls, self.state_drops = state.lag, state.stalls, state.dropped
            self.report_drops = state.reports_dropped
            for listener in self._feedback_listeners:
                try:
                    listener()
                except Exception:
                    log.exception('feedback listener failed')

    def _read_stops(self) -> None:
        while True:
            try:
                record = self.stop_lane.recv()
            except Exception as exc:
                log.error('stop lane: %s', exc)
                continue
            if record is None:
                self._lost('stop lane closed')
                return
            self._answer(record)

    def _read_requests(self) -> None:
        while True:
            try:
                record = self.request_lane.recv()
            except Exception as exc:
                log.error('request lane: %s', exc)
                continue
            if record is None:
                self._lost('request lane closed')
                return
            try:
                self._on_report(record)
            except Exception:
                log.exception('handling %s failed', type(record).__name__)

    def _answer(self, record: object) -> None:
        if not isinstance(record, Reply | Failure):
            return
        with self._pending_lock:
            future = self._pending.pop(record.id, None)
        if future is None or future.done():
            return
        if isinstance(record, Reply):
            value = record.value
            if isinstance(value, StopOutcome):  # the joints' states first: the caller reads its effect
                self._apply_states(value.states)
                value = dict(value.errors)
            elif isinstance(value, AxisStates):
                self._apply_states(value)
                value = None
            future.set_result(value)
        else:
            if record.states is not None:  # the joint's state after the failed intent, first
                self._apply_states(record.states)
            future.set_exception(exception(record))

    def _on_report(self, record: object) -> None:
        if isinstance(record, Reply | Failure):
            self._answer(record)
        elif isinstance(record, AxisStates):
            self._apply_states(record)
        elif isinstance(record, Frames):
            self.frame_drops = record.dropped
            self._on_frames(record)
        elif isinstance(record, BusEvent):
            self.events = [*self.events[-(EVENTS_KEPT - 1):], record]
            self._notify(self._event_listeners, record)
        elif isinstance(record, EmcyEvent):
            self._notify(self._emcy_listeners, record)
        elif isinstance(record, HandleState):
            self.executor.on_handle(record)
        elif isinstance(record, CommandRefused):
            for listener in self._refusal_listeners:
                listener(record.topic, record.reason)
        elif isinstance(record, Ready):
            self._ready.set_result(record)
        elif isinstance(record, StartFailed):
            self._ready.set_exception(BusProcessStartError(record.message))
        elif isinstance(record, Farewell):
            log.info('bus process ends: %s', record.reason)
            self.final = record.final

    def _apply_states(self, states: AxisStates) -> None:
        """Each joint's snapshot, unless one taken later was applied already (the stop lane's
        answer may overtake a report still queued on the request lane)."""
        with self._taken_lock:
            for snapshot, field, strategy in zip(states.snapshots, states.command_fields, states.strategies):
                axis = self.axes.get(snapshot.joint)
                if axis is None or states.taken < self._taken.get(snapshot.joint, float('-inf')):
                    continue
                self._taken[snapshot.joint] = states.taken
                axis.on_snapshot(snapshot, field, strategy)

    @staticmethod
    def _notify(listeners: Sequence[Callable[[Any], None]], record: object) -> None:
        for listener in listeners:
            try:
                listener(record)
            except Exception:
                log.exception('listener failed')

    def _on_frames(self, record: Frames) -> None:
        listeners = self._frame_listeners
        if not listeners:
            return
        for ts, can_id, ext, rtr, err, dlc, data, rx, fd in unpack_frames(record.data):
            msg = can.Message(timestamp=ts, arbitration_id=can_id, is_extended_id=ext, is_remote_frame=rtr,
                              is_error_frame=err, dlc=dlc, data=data, is_rx=rx, is_fd=fd, check=False)
            for listener in listeners:
                try:
                    listener(msg)
                except Exception:
                    log.exception('frame listener failed')

