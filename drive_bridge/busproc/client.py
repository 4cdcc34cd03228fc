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

from drive_bridge.busproc import wire
from drive_bridge.busproc.commands import CommandSender
from drive_bridge.busproc.errors import BusProcessLost, BusProcessStartError
from drive_bridge.busproc.executor import ExecutorProxy
from drive_bridge.busproc.inbox import Inbox
from drive_bridge.busproc.intents import (
    InjectSetpoint,
    Nmt,
    Query,
    Request,
    SdoRead,
    SdoWrite,
    Settings,
    Shutdown,
    Start,
    Stop,
)
from drive_bridge.busproc.proxies import AxisProxy, NodeProxy, ParameterAccessProxy
from drive_bridge.busproc.reports import Ready
from drive_bridge.busproc.snapshots import SnapshotCache
from drive_bridge.config.source import ConfigSource
from drive_bridge.families import get_family
from drive_bridge.families.errors import ParameterError
from drive_bridge.families.parameters import ParameterAccess
from drive_bridge.joint import Setpoint
from drive_bridge.master.master import BusSnapshot
from drive_bridge.master.sdo import SdoPlain
from drive_bridge.model import BusConfig

log = logging.getLogger('drive_bridge.busproc')

START_TIMEOUT = 60.0  # s for the bus process to open the bus (imports, simulated drives)
SHUTDOWN_TIMEOUT = 10.0  # s for it to stop the axes and release the bus when asked
CALL_TIMEOUT = 30.0  # s for an answer to a request without a timeout of its own


class BusClient(Inbox):
    def __init__(self, config: BusConfig, source: ConfigSource, *, pvt_segment: float = 0.01,
                 pvt_lookahead: float = 0.05) -> None:
        super().__init__()
        self.config = config
        self.source = source
        period = config.master.cycle_period
        self.nodes = {n.name: NodeProxy(n, get_family(n.family)) for n in config.nodes}
        self._by_id = {n.node_id: n for n in self.nodes.values()}
        self.axes = {a.joint: AxisProxy(self, n, a, period) for n in config.nodes for a in n.axes}
        self.joints = list(self.axes)
        self.executor = ExecutorProxy(self, pvt_segment, pvt_lookahead)
        self.lost = ''  # why the bus process is gone ('' while it runs)
        self.pid = 0
        self.process: subprocess.Popen[bytes] | None = None
        self._ids = itertools.count(1)
        self._lost_once = threading.Lock()
        self.snapshots = SnapshotCache(self)
        self.commands = CommandSender(self, period)
        self._threads: list[threading.Thread] = []
        self.started = False
        self._closing = False
        self.abandoned = False  # this process is dying: the bus process was left to a node-loss stop

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
        self._threads.extend(self.start_readers())
        watcher = threading.Thread(target=self._watch_child, name='drive_bridge-client-watch', daemon=True)
        self._threads.append(watcher)
        watcher.start()
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

    def abandon(self) -> None:
        """This process is dying (an unhandled exception): end the lanes without asking for a
        shutdown, so the bus process stops every enabled axis as for a lost node (``safestop``:
        quick stop, at rest, then disabled or held) and exits unless an axis holds. It is neither
        waited for nor ended here; :meth:`close` does nothing afterwards."""
        if self.abandoned or self.process is None:
            return
        self.abandoned = self._closing = True
        log.error('the node process is dying: its bus process %d stops the axes as for a lost node', self.pid)
        self.commands.stop()
        for lane in (self.stop_lane, self.request_lane, self.state_lane):
            lane.close()

    def close(self, timeout: float = SHUTDOWN_TIMEOUT) -> None:
        """Ask the bus process to stop the axes and release the bus; end it if it does not."""
        if self.abandoned:
            return
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

    def inject_setpoint(self, joint: str, setpoint: Setpoint) -> None:
        """The test hook ``intents.InjectSetpoint`` (refused unless the bus process was started
        with DRIVE_BRIDGE_TEST_HOOKS=1)."""
        self.call(InjectSetpoint(joint, setpoint.position, setpoint.velocity, setpoint.effort), 10.0)

    def settings(self, **changes: object) -> None:
        if not self.lost and self.started:
            self.call_async(Settings(**changes))  # type: ignore[arg-type]

    def capture(self, path: str) -> None:
        """Start a timing capture of the bus into ``path`` ('': stop it and write the file);
        waits until the bus process has done it."""
        self.call(Settings(capture=path), 30.0)

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

