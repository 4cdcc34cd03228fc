"""The node process's side: :class:`BusClient` starts the bus process as its child, supervises
it, and offers the ROS layer the Master's API (axes, nodes, SDO, NMT, parameters, events,
frames, snapshots) with :class:`~.executor.ExecutorProxy` as the trajectory executor.

Threads: one reader per lane (cyclic state, request-lane reports, stop answers), the child's
watcher, and the direct-command sender. When the bus process is gone (a lane at end of stream,
or the child exited), every joint is unavailable at once, every waiting request fails with
:class:`~.errors.BusProcessLost`, and the lost listeners are told why.
"""
from __future__ import annotations

import concurrent.futures
import itertools
import logging
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import can

from drive_bridge.busproc import cyclic, wire
from drive_bridge.busproc.commands import CommandSender
from drive_bridge.busproc.errors import BusProcessLost, BusProcessStartError
from drive_bridge.busproc.executor import ExecutorProxy
from drive_bridge.busproc.failures import exception
from drive_bridge.busproc.intents import Nmt, Query, Request, SdoRead, SdoWrite, Settings, Shutdown, Start, Stop
from drive_bridge.busproc.proxies import AxisProxy, NodeProxy, ParameterAccessProxy
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
from drive_bridge.busproc.snapshots import SnapshotCache
from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.config.busbudget import UPDATE_PERIOD_WITHOUT_SYNC
from drive_bridge.config.source import ConfigSource
from drive_bridge.families import get_family
from drive_bridge.families.parameters import ParameterAccess, ParameterError
from drive_bridge.master.events import BusEvent
from drive_bridge.master.master import BusSnapshot
from drive_bridge.master.sdo import SdoPlain
from drive_bridge.model import BusConfig

log = logging.getLogger('drive_bridge.busproc')

START_TIMEOUT = 60.0  # s for the bus process to open the bus (imports, simulated drives)
SHUTDOWN_TIMEOUT = 10.0  # s for it to stop the axes and release the bus when asked
CALL_TIMEOUT = 30.0  # s for an answer to a request without a timeout of its own
STOP_TIMEOUT = 2.0  # s for the stop lane's answer that trajectories ended
EVENTS_KEPT = 200


class BusClient:
    def __init__(self, config: BusConfig, source: ConfigSource, *, pvt_segment: float = 0.01,
                 pvt_lookahead: float = 0.05) -> None:
        self.config = config
        self.source = source
        period = config.master.sync_period or UPDATE_PERIOD_WITHOUT_SYNC
        self.nodes = {n.name: NodeProxy(n, get_family(n.family)) for n in config.nodes}
        self._by_id = {n.node_id: n for n in self.nodes.values()}
        self.axes = {a.joint: AxisProxy(self, n, a, period) for n in config.nodes for a in n.axes}
        self.joints = list(self.axes)
        self.executor = ExecutorProxy(self, pvt_segment, pvt_lookahead)
        self.events: list[BusEvent] = []
        self.lost = ''  # why the bus process is gone ('' while it runs)
        self.pid = 0
        self.frame_drops = 0  # frames the bus process could not forward (its queue was full)
        self.state_drops = 0  # cyclic states it could not send (this process's buffer was full)
        self.process: subprocess.Popen[bytes] | None = None
        self._ids = itertools.count(1)
        self._pending: dict[int, concurrent.futures.Future[object]] = {}
        self._pending_lock = threading.Lock()
        self._ready: concurrent.futures.Future[Ready] = concurrent.futures.Future()
        self._event_listeners: list[Callable[[BusEvent], None]] = []
        self._emcy_listeners: list[Callable[[EmcyEvent], None]] = []
        self._feedback_listeners: list[Callable[[], None]] = []
        self._frame_listeners: list[Callable[[can.Message], None]] = []
        self._lost_listeners: list[Callable[[str], None]] = []
        self._refusal_listeners: list[Callable[[str, str], None]] = []
        self._lost_once = threading.Lock()
        self.snapshots = SnapshotCache(self)
        self.commands = CommandSender(self, period)
        self._threads: list[threading.Thread] = []
        self.started = False
        self._closing = False

    # -- lifecycle -------------------------------------------------------------------------------------
    def start(self, timeout: float = START_TIMEOUT) -> Ready:
        """Start the bus process and wait until its bus is open; BusProcessStartError with its
        own message when it cannot start (nothing is left running)."""
        node_ends, child_ends = zip(*(wire.lane_pair() for _ in range(3)))
        self.stop_lane, self.request_lane, self.state_lane = (wire.Lane(end) for end in node_ends)
        fds = [end.fileno() for end in child_ends]
        command = [sys.executable, '-m', 'drive_bridge.busproc', '--lanes', ','.join(map(str, fds))]
        self.process = subprocess.Popen(command, pass_fds=fds, stdin=subprocess.DEVNULL, close_fds=True)
        for end in child_ends:
            end.close()
        self.pid = self.process.pid
        for target, name in ((self._read_state, 'state'), (self._read_requests, 'requests'),
                             (self._read_stops, 'stops'), (self._watch_child, 'watch')):
            thread = threading.Thread(target=target, name=f'drive_bridge-client-{name}', daemon=True)
            self._threads.append(thread)
            thread.start()
        frames = bool(self._frame_listeners)
        self.request_lane.send(Start(self.source, self.executor.pvt_segment, self.executor.pvt_lookahead, frames))
        try:
            ready = self._ready.result(timeout)
        except concurrent.futures.TimeoutError:
            self._kill()
            raise BusProcessStartError(f'the bus process did not open the bus within {timeout:g} s') from None
        except BusProcessStartError:
            self._kill()
            raise
        self.started = True
        self.commands.start()
        return ready

    def close(self, timeout: float = SHUTDOWN_TIMEOUT) -> None:
        """Ask the bus process to stop the axes and release the bus; end it if it does not."""
        self._closing = True
        self.commands.stop()
        process = self.process
        if process is None:
            return
        if not self.lost:
            try:
                self.call(Shutdown(), 2.0)
            except Exception as exc:
                log.warning('bus process shutdown: %s', exc)
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            log.error('bus process %d did not end within %g s: terminating it', process.pid, timeout)
            self._kill()
        self._lost('closed')
        for lane in (self.stop_lane, self.request_lane, self.state_lane):
            lane.close()

    def _kill(self) -> None:
        process = self.process
        if process is None or process.poll() is not None:
            return
        process.terminate()
        try:
            process.wait(5.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(5.0)

    def _lost(self, reason: str) -> None:
        if not self._lost_once.acquire(blocking=False):
            return
        if self._closing:
            reason = 'closed'
        process = self.process
        if process is not None and reason != 'closed':
            try:  # the exit code says more than the closed lane (it follows within ms)
                code = process.wait(0.05)
                reason = f'{reason}; bus process {process.pid} {ending(code)}'
            except subprocess.TimeoutExpired:
                pass
        self.lost = reason = f'bus process lost: {reason}' if reason != 'closed' else 'bus process ended'
        for axis in self.axes.values():
            axis.on_lost(reason)
        self.executor.on_lost(reason)
        if not self._ready.done():
            self._ready.set_exception(BusProcessStartError(reason))
        with self._pending_lock:
            pending, self._pending = self._pending, {}
        for future in pending.values():
            if not future.done():
                future.set_exception(BusProcessLost(reason))
        if reason == 'bus process ended':  # asked to end (close): nothing to report
            return
        for listener in self._lost_listeners:
            try:
                listener(reason)
            except Exception:
                log.exception('lost listener failed')

    # -- requests ----------------------------------------------------------------------------------------
    def _send(self, lane: wire.Lane, body: object) -> concurrent.futures.Future[object]:
        future: concurrent.futures.Future[object] = concurrent.futures.Future()
        if self.lost:
            future.set_exception(BusProcessLost(self.lost))
            return future
        request_id = next(self._ids)
        with self._pending_lock:
            self._pending[request_id] = future
        try:
            lane.send(Request(request_id, body))
        except Exception as exc:
            with self._pending_lock:
                self._pending.pop(request_id, None)
            future.set_exception(exc if not isinstance(exc, OSError) else BusProcessLost(self.lost or str(exc)))
        return future

    def post(self, body: object) -> None:
        """Send a request that has no answer (direct commands: refused ones are reported)."""
        if self.lost:
            raise BusProcessLost(self.lost)
        try:
            self.request_lane.send(Request(0, body))
        except OSError as exc:
            raise BusProcessLost(self.lost or str(exc)) from None

    def call_async(self, body: object) -> concurrent.futures.Future[object]:
        """Send a request on the request lane; the future holds its answer or its error."""
        return self._send(self.request_lane, body)

    def call(self, body: object, timeout: float | None = None) -> object:
        """Send a request and wait for its answer (its error raised as the bus process raised it)."""
        future = self.call_async(body)
        try:
            return future.result(timeout if timeout is not None else CALL_TIMEOUT)
        except concurrent.futures.TimeoutError:
            raise TimeoutError(f'{type(body).__name__}: no answer from the bus process within '
                               f'{timeout if timeout is not None else CALL_TIMEOUT:g} s') from None

    def stop(self, body: Stop) -> concurrent.futures.Future[object]:
        """A stop on the stop lane: never queued behind other requests."""
        return self._send(self.stop_lane, body)

    # -- the Master's API ----------------------------------------------------------------------------------
    def node_by_id(self, node_id: int) -> NodeProxy | None:
        return self._by_id.get(node_id)

    def sdo_read(self, node_id: int, index: int, subindex: int, data_type: int = 0) -> tuple[int, SdoPlain, bytes]:
        value = self.call(SdoRead(node_id, index, subindex, data_type))
        assert isinstance(value, tuple)
        return value

    def sdo_write(self, node_id: int, index: int, subindex: int, value: SdoPlain, data_type: int = 0) -> int:
        used = self.call(SdoWrite(node_id, index, subindex, value, data_type))
        assert isinstance(used, int)
        return used

    def nmt(self, command: int, node_id: int = 0) -> None:
        self.call(Nmt(command, node_id))

    def wait_until_operational(self, timeout: float, names: list[str] | None = None) -> None:
        self.call(Query('operational', tuple(names or ()), timeout=timeout), timeout + 5.0)

    def parameter_access(self, node_id: int) -> ParameterAccess:
        if node_id not in self._by_id:
            known = ', '.join(f'{n.node_id} ({n.name})' for n in self.nodes.values())
            raise ParameterError(f'node {node_id} is not in the bus configuration (configured: {known})',
                                 node_id=node_id)
        return ParameterAccessProxy(lambda body, timeout: self.call(body, timeout), node_id)

    def snapshot(self) -> BusSnapshot:
        """The bus as last reported (at most a diagnostics period old; a fresh one is asked for)."""
        return self.snapshots.get()

    def settings(self, **changes: object) -> None:
        if not self.lost and self.started:
            self.call_async(Settings(**changes))  # type: ignore[arg-type]

    def capture(self, path: str) -> None:
        """Start a timing capture of the bus into ``path`` ('': stop it and write the file);
        waits until the bus process has done it."""
        self.call(Settings(capture=path), 30.0)

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

    def _apply_states(self, states: AxisStates) -> None:
        for snapshot, field, strategy in zip(states.snapshots, states.command_fields, states.strategies):
            axis = self.axes.get(snapshot.joint)
            if axis is not None:
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

    def _watch_child(self) -> None:
        process = self.process
        assert process is not None
        code = process.wait()
        time.sleep(0.01)  # let a lane's end of stream name the cause first, where there is one
        self._lost(f'bus process {process.pid} {ending(code)}')


def ending(code: int) -> str:
    """How a process ended, from its exit code (negative: the signal that killed it)."""
    if code >= 0:
        return f'exited with code {code}'
    try:
        name = signal.Signals(-code).name
    except ValueError:
        name = 'unknown signal'
    return f'was killed by signal {-code} ({name})'

