"""The bus process's side of the boundary: the lanes read, every intent carried out on the
Master and the trajectory executor, the state sent back.

Threads (besides the Master's own: cycle, CAN receive, supervision, boots):
- the **stop lane** reader: ends trajectories at once and starts each joint's stop intent in
  a thread of its own; it never waits behind anything;
- the **request lane** reader: cheap requests (queries, settings, direct commands, trajectory
  chunks) inline; those that wait on the bus go to :class:`~.workers.Workers` (bounded), a
  complete trajectory to its own single worker (validation is the costly part);
- the outbox's sender (:mod:`.outbox`).
The cyclic state is sent from the cycle and CAN threads without waiting (:mod:`.cyclic`).
When a lane reports end of stream the node process is gone: :mod:`.safestop` runs once.
"""
from __future__ import annotations

import dataclasses
import logging
import threading
from collections.abc import Callable
from typing import Any

from drive_bridge.busproc import cyclic, wire
from drive_bridge.busproc.capture import Capture
from drive_bridge.busproc.errors import BoundaryError, Busy
from drive_bridge.busproc.failures import failure
from drive_bridge.busproc.handlers import Handlers
from drive_bridge.busproc.intents import (
    AxisIntent,
    DirectCommands,
    Query,
    Request,
    Settings,
    Shutdown,
    Stop,
    TrajectoryChunk,
)
from drive_bridge.busproc.outbox import Outbox, axis_states
from drive_bridge.busproc.reports import Failure, HandleState, Reply, StopOutcome
from drive_bridge.busproc.workers import Workers
from drive_bridge.master.master import Master
from drive_bridge.streaming.executor import TrajectoryExecutor, TrajectoryHandle

log = logging.getLogger('drive_bridge.busproc')

WORKERS = 8  # requests that wait on the bus (SDO, NMT, parameters, axis intents) at once
MAX_PENDING = 32  # of them running or waiting; more are refused at once
TRAJECTORIES_PENDING = 16  # trajectories validated one at a time: this many running or waiting (a burst of small ones)


class BusServer:
    """Serves one node process over three lanes; ``on_lost(reason)`` is called once when the
    node process is gone, ``on_shutdown(reason)`` when it asks the bus process to end."""

    def __init__(self, master: Master, stop_lane: wire.Lane, request_lane: wire.Lane, state_lane: wire.Lane,
                 on_lost: Callable[[str], None], on_shutdown: Callable[[str], None]) -> None:
        """Listens to the master's events and frames at once (before it starts: the node and its
        recording see the boot); :meth:`start` serves the lanes once the bus is open."""
        self.master = master
        self.stop_lane = stop_lane
        self.request_lane = request_lane
        self.state_lane = state_lane
        self.joints: list[str] = []
        self.outbox = Outbox(request_lane, self._lost)
        self.executor: TrajectoryExecutor | None = None
        self.handlers: Handlers | None = None
        self.workers = Workers(WORKERS, MAX_PENDING, 'drive_bridge-busproc')
        self.trajectory_worker = Workers(1, TRAJECTORIES_PENDING, 'drive_bridge-trajectory')
        self._on_lost = on_lost
        self._on_shutdown = on_shutdown
        self._lost_once = threading.Lock()
        self.lost = False
        self._sequence = 0
        self.state_dropped = 0
        self._sent_on_feedback = False
        self._state_lock = threading.Lock()
        self._handles: dict[int, tuple[TrajectoryHandle, tuple[str, str]]] = {}
        self._threads = [threading.Thread(target=self._read_stops, name='drive_bridge-stop-lane', daemon=True),
                         threading.Thread(target=self._read_requests, name='drive_bridge-request-lane', daemon=True)]
        master.add_event_listener(self.outbox.put)
        master.add_emcy_listener(self.outbox.put)
        master.add_frame_listener(self.outbox.on_frame)
        self.capture = Capture()
        master.add_frame_listener(self.capture.on_frame)

    def start(self, executor: TrajectoryExecutor) -> None:
        """Serve the lanes: the master has started (its axes exist) and ``executor`` runs them."""
        master = self.master
        self.executor = executor
        self.joints = list(master.axes)
        self.handlers = Handlers(master, executor, self.outbox.put)
        self.outbox.watch_axes(master.axes)
        master.add_feedback_listener(self._on_feedback)
        master.add_cycle_listener(self._on_cycle)
        self.outbox.start()
        for thread in self._threads:
            thread.start()

    def close(self) -> None:
        self.workers.shutdown()
        self.trajectory_worker.shutdown()
        self.outbox.stop()

    def _lost(self, reason: str) -> None:
        if not self._lost_once.acquire(blocking=False):
            return
        self.lost = True
        threading.Thread(target=self._on_lost, args=(reason,), name='drive_bridge-node-lost', daemon=True).start()

    # -- cyclic state (cycle and CAN threads: never wait) ------------------------------------------
    def _on_feedback(self) -> None:
        self._sent_on_feedback = True
        self._send_state()

    def _on_cycle(self, _cycle: int) -> None:
        if self._sent_on_feedback:  # this cycle's TPDOs came and were sent
            self._sent_on_feedback = False
        else:
            self._send_state()
        self.outbox.check_axes()
        self._check_handles()

    def _send_state(self) -> None:
        if self.lost or not self._state_lock.acquire(blocking=False):
            return  # the other thread sends this cycle's state right now
        try:
            axes, executor = self.master.axes, self.executor
            assert executor is not None
            self._sequence += 1
            data = cyclic.pack(self._sequence, executor.lag, executor.stalls, self.state_dropped,
                               [axes[j].feedback() for j in self.joints],
                               reports_dropped=self.outbox.dropped_records)
            if not self.state_lane.send_nowait(data):
                self.state_dropped += 1
        except OSError as exc:
            self._lost(f'state lane closed ({exc})')
        finally:
            self._state_lock.release()

    def watch(self, handle: TrajectoryHandle) -> None:
        """Report this handle's changes (pending -> active -> how it ended) to the node."""
        self._handles[handle.id] = (handle, (handle.state, handle.reason))

    def _check_handles(self) -> None:
        for key, (handle, last) in list(self._handles.items()):
            now = (handle.state, handle.reason)
            if now != last:
                self.outbox.put(handle_state(handle))
                if handle.finished:
                    del self._handles[key]
                else:
                    self._handles[key] = (handle, now)

    # -- the stop lane ------------------------------------------------------------------------------
    def _read_stops(self) -> None:
        lane = self.stop_lane
        while True:
            try:
                request = lane.recv()
            except BoundaryError as exc:
                log.error('stop lane: %s', exc)
                continue
            if request is None:
                self._lost('stop lane closed')
                return
            if not isinstance(request, Request) or not isinstance(request.body, Stop):
                log.error('stop lane: not a stop request: %r', type(request).__name__)
                continue
            self._stop(request.id, request.body)

    def _stop(self, request_id: int, stop: Stop) -> None:
        """End the trajectories here and now; each joint's intent in a thread of its own."""
        joints = [j for j in stop.joints if j in self.master.axes]
        assert self.executor is not None
        try:
            self.executor.stop(joints, stop.reason or stop.action, stop.state, stop.smooth)
        except Exception as exc:
            log.exception('stop: ending trajectories failed')
            self._answer_stop(Failure(request_id, 'internal', repr(exc)))
            return
        if stop.action == 'trajectories':
            self._answer_stop(Reply(request_id, StopOutcome(tuple((j, '') for j in joints), axis_states([]))))
            return
        outcome: dict[str, str] = {}
        threads = [threading.Thread(target=self._stop_joint, args=(joint, stop, outcome), daemon=True,
                                    name=f'drive_bridge-stop-{joint}') for joint in joints]
        for thread in threads:
            thread.start()

        def answer() -> None:
            for thread in threads:
                thread.join()
            states = axis_states([self.master.axes[j] for j in joints])  # the answer shows its effect
            self._answer_stop(Reply(request_id, StopOutcome(tuple((j, outcome.get(j, '')) for j in joints), states)))
        threading.Thread(target=answer, daemon=True, name='drive_bridge-stop-answer').start()

    def _stop_joint(self, joint: str, stop: Stop, outcome: dict[str, str]) -> None:
        axis = self.master.axes[joint]
        try:
            if stop.action == 'quick_stop':
                axis.quick_stop(stop.timeout)
            elif stop.action == 'halt':
                axis.halt(True)
            else:
                axis.disable(stop.timeout)
            outcome[joint] = ''
        except Exception as exc:
            outcome[joint] = str(exc) or repr(exc)

    def _answer_stop(self, record: Reply | Failure) -> None:
        try:
            self.stop_lane.send(record)
        except OSError as exc:
            self._lost(f'stop lane closed ({exc})')

    # -- the request lane ---------------------------------------------------------------------------
    def _read_requests(self) -> None:
        lane = self.request_lane
        while True:
            try:
                request = lane.recv()
            except BoundaryError as exc:
                log.error('request lane: %s', exc)
                continue
            if request is None:
                self._lost('request lane closed')
                return
            if not isinstance(request, Request):
                log.error('request lane: not a request: %r', type(request).__name__)
                continue
            try:
                self._dispatch(request)
            except Exception as exc:  # a bug must still answer
                log.exception('request %s failed', type(request.body).__name__)
                self.outbox.put(failure(request.id, exc))

    def _dispatch(self, request: Request) -> None:
        body, handlers = request.body, self.handlers
        assert handlers is not None
        if isinstance(body, Shutdown):
            self.outbox.put(Reply(request.id, None))
            self._on_shutdown(body.reason)
        elif isinstance(body, DirectCommands):
            handlers.commands(body)
        elif isinstance(body, Settings):
            self._settings(body)
            self.outbox.put(Reply(request.id, None))
        elif isinstance(body, Query) and body.what != 'operational':
            self.outbox.put(Reply(request.id, handlers.query(body)))
        elif isinstance(body, TrajectoryChunk):
            trajectory = handlers.add_chunk(body)
            if trajectory is None:
                self.outbox.put(Reply(request.id, None))
            else:
                self._submit(request.id, lambda: self._watched(handlers.submit(body.source, trajectory)))
        else:
            joint = body.joint if isinstance(body, AxisIntent) else None
            self._submit(request.id, lambda: handlers.run(body), self.workers, joint)

    def _watched(self, handle: TrajectoryHandle | None) -> HandleState | None:
        if handle is None:
            return None
        self.watch(handle)
        return handle_state(handle)

    def _submit(self, request_id: int, work: Callable[[], Any], workers: Workers | None = None,
                joint: str | None = None) -> None:
        """Run ``work`` in a worker; a failed axis intent's answer carries its ``joint``'s state."""
        def run() -> None:
            try:
                self.outbox.put(Reply(request_id, work()))
            except Exception as exc:
                record = failure(request_id, exc)
                if joint is not None and joint in self.master.axes:
                    record = dataclasses.replace(record, states=axis_states([self.master.axes[joint]]))
                self.outbox.put(record)
        try:
            (workers or self.trajectory_worker).submit(run)
        except Busy as exc:
            self.outbox.put(Failure(request_id, 'busy', str(exc)))

    def _settings(self, settings: Settings) -> None:
        assert self.executor is not None
        if settings.frames is not None:
            self.outbox.forward_frames = settings.frames
            if not settings.frames:
                self.outbox.frames.clear()
        if settings.capture is not None:
            self.capture.set(settings.capture)
        if settings.pvt_segment is not None:
            self.executor.pvt_segment = settings.pvt_segment
        if settings.pvt_lookahead is not None:
            self.executor.pvt_lookahead = settings.pvt_lookahead


def handle_state(handle: TrajectoryHandle) -> HandleState:
    return HandleState(handle.id, handle.joints, handle.start, handle.end, handle.state, handle.reason,
                       handle.notes, handle.warnings)

