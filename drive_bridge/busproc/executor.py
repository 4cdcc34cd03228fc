"""The trajectory executor of the bus process, as the node process sees it (the
``TrajectoryExecutor`` API the ROS layer used): submit, stop, the stream clock, desired states.

A trajectory crosses in chunks of ``intents.chunk_points`` points (at most
``intents.CHUNK_POINTS``), each sent once the one before it is acknowledged; the answer to the
last is the handle, kept up to date by the bus process's HandleState reports. Stops go on the
stop lane.
"""
from __future__ import annotations

import concurrent.futures
import itertools
import threading
import time
from collections.abc import Iterable

from drive_bridge.busproc.intents import Query, Stop, TrajectoryChunk, chunk_points
from drive_bridge.busproc.ports import ExecutorClient
from drive_bridge.busproc.proxies import HandleProxy
from drive_bridge.busproc.reports import FeederState, HandleState
from drive_bridge.joint.strategy import NOT_STREAMED
from drive_bridge.streaming.trajectory import JointSample, Trajectory

SUBMIT_TIMEOUT = 30.0  # s for a trajectory's validation and answer (the sync submit)
STOP_TIMEOUT = 2.0  # s for the stop lane's answer that the trajectories ended


class ExecutorProxy:
    def __init__(self, client: ExecutorClient, pvt_segment: float, pvt_lookahead: float) -> None:
        self.client = client
        self._pvt_segment = pvt_segment
        self._pvt_lookahead = pvt_lookahead
        self.lag = 0.0  # from the cyclic state
        self.stalls = 0
        self._handles: dict[int, HandleProxy] = {}
        self._lock = threading.Lock()
        self._submissions = itertools.count(1)

    # -- settings ---------------------------------------------------------------------------------------
    @property
    def pvt_segment(self) -> float:
        return self._pvt_segment

    @pvt_segment.setter
    def pvt_segment(self, value: float) -> None:
        self._pvt_segment = value
        self.client.settings(pvt_segment=value)

    @property
    def pvt_lookahead(self) -> float:
        return self._pvt_lookahead

    @pvt_lookahead.setter
    def pvt_lookahead(self, value: float) -> None:
        self._pvt_lookahead = value
        self.client.settings(pvt_lookahead=value)

    # -- the executor's API ------------------------------------------------------------------------------
    def now(self) -> float:
        """The stream clock: wall time minus the delay stalled cycles accumulated."""
        return time.time() - self.lag

    def strategy(self, joint: str) -> str:
        return self.client.axes[joint].stream_strategy() or NOT_STREAMED

    def desired(self, joint: str, t: float) -> JointSample | None:
        samples = self.client.call(Query('desired', (joint,), at=t), 5.0)
        assert isinstance(samples, dict)
        sample = samples.get(joint)
        return sample if isinstance(sample, JointSample) else None

    def feeder(self, joint: str) -> FeederState | None:
        """The PVT feeder of a joint as it is now in the bus process (a test query)."""
        feeders = self.client.call(Query('feeders', (joint,)), 5.0)
        assert isinstance(feeders, dict)
        return feeders.get(joint)

    def active(self) -> list[HandleProxy]:
        with self._lock:
            return [h for h in self._handles.values() if not h.finished]

    def submit(self, trajectory: Trajectory, source: str = 'trajectory') -> HandleProxy | None:
        """Validate (in the bus process) and schedule; TrajectoryError says why it was refused."""
        try:
            return self.submit_async(trajectory, source).result(SUBMIT_TIMEOUT)
        except concurrent.futures.TimeoutError:
            raise TimeoutError(f'{source}: no answer from the bus process within {SUBMIT_TIMEOUT:g} s') from None

    def submit_async(self, trajectory: Trajectory, source: str = 'trajectory'
                     ) -> concurrent.futures.Future[HandleProxy | None]:
        """As :meth:`submit`, without waiting: the future holds the handle (None for an empty
        trajectory, which stops its joints) or the refusal."""
        result: concurrent.futures.Future[HandleProxy | None] = concurrent.futures.Future()
        points = trajectory.points
        size = chunk_points(len(trajectory.joints))
        parts = [points[i:i + size] for i in range(0, len(points), size)] or [()]
        submission = next(self._submissions)

        def send(index: int) -> None:
            chunk = TrajectoryChunk(submission, index, len(parts), trajectory.joints, parts[index],
                                    trajectory.start, source)
            self.client.call_async(chunk).add_done_callback(lambda answer: answered(index, answer))

        def answered(index: int, answer: concurrent.futures.Future[object]) -> None:
            error = answer.exception()
            if error is not None:
                result.set_exception(error)
            elif index + 1 < len(parts):
                send(index + 1)
            else:
                value = answer.result()
                result.set_result(self._handle(value) if isinstance(value, HandleState) else None)
        send(0)
        return result

    def stop(self, joints: Iterable[str], reason: str, state: str = 'cancelled', smooth: bool = False) -> None:
        """End the joints' trajectories and hold them (stop lane; waits for the bus process to say so)."""
        joints = tuple(joints)
        if not joints or self.client.lost:
            return
        future = self.client.stop(Stop(joints, 'trajectories', reason, state, smooth))
        try:
            future.result(STOP_TIMEOUT)
        except concurrent.futures.TimeoutError:
            raise TimeoutError(f'stopping {", ".join(joints)}: no answer from the bus process within '
                               f'{STOP_TIMEOUT:g} s') from None

    # -- handles -------------------------------------------------------------------------------------------
    def _handle(self, state: HandleState) -> HandleProxy:
        with self._lock:
            handle = self._handles.get(state.id)
            if handle is None:  # else a newer report came first: keep it
                handle = self._handles[state.id] = HandleProxy.of(state)
            self._forget_finished()
            return handle

    def on_handle(self, state: HandleState) -> None:
        with self._lock:
            handle = self._handles.get(state.id)
            if handle is None:
                self._handles[state.id] = HandleProxy.of(state)
            else:
                handle.update(state)

    def _forget_finished(self) -> None:
        if len(self._handles) > 100:
            for key in [k for k, h in self._handles.items() if h.finished][:-50]:
                del self._handles[key]

    def on_lost(self, reason: str) -> None:
        with self._lock:
            for handle in self._handles.values():
                handle.finish('aborted', reason)
