"""Stopping a drive that runs on by itself (its family's ``boot.runs_on_without_master``) once the
bridge has lost its liveness (heartbeat or guarding) while its frames still arrive: such a drive
keeps its last references, so the bridge keeps sending its family's stop, by PDO every cycle and
by SDO every ``SDO_PERIOD``, until the drive reports it is at rest or its frames stop (gone),
and reports the start, a failing SDO and the end once each. Gone is not the end: frames that
arrive again while its liveness is still lost (a pause of the bus, a busy machine) mean it may
still be running, and the stop is sent again.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from drive_bridge.master.node import BootState, NodeRuntime

SDO_PERIOD = 0.2  # s between two SDO stops of one node
FRAMES_FRESH = 0.25  # s: a node whose last process data is older is gone (not sending)


@dataclass
class _Stopping:
    since: float
    last_sdo: float = 0.0
    sdo_failed: bool = False


class RunOnStop:
    """Per node: whether its stop is being sent, and the reports (``report(node, level, text)``)."""

    def __init__(self, report: Callable[[NodeRuntime, str, str], None]) -> None:
        self.report = report
        self._stopping: dict[int, _Stopping] = {}
        self._done: set[int] = set()  # at rest in this loss: nothing more sent
        self._gone: set[int] = set()  # its frames stopped in this loss: the stop resumes if they return

    @staticmethod
    def frames_arrive(node: NodeRuntime, now: float) -> bool:
        stamps = node.process.input_stamps
        return bool(stamps) and now - max(stamps.values()) < FRAMES_FRESH

    def due(self, node: NodeRuntime) -> bool:
        """The node's stop goes out this cycle (cycle thread): lost, running on, still sending."""
        if not node.family.boot.runs_on_without_master or node.boot_state is not BootState.LOST:
            self._finish(node, '')
            self._done.discard(node.node_id)
            self._gone.discard(node.node_id)
            return False
        if node.node_id in self._done:
            return False
        now = time.time()
        if not self.frames_arrive(node, now):
            if self._finish(node, 'its frames stopped (gone): stop no longer sent, sent again if they return'):
                self._gone.add(node.node_id)
            return False
        if node.node_id not in self._stopping:
            self._stopping[node.node_id] = _Stopping(now)
            if node.node_id in self._gone:
                self._gone.discard(node.node_id)
                self.report(node, 'error', f'node {node.node_id} ({node.name}): its frames arrive again while its '
                                           'liveness is still lost: sending its stop again')
            else:
                self.report(node, 'error', f'node {node.node_id} ({node.name}): liveness lost while its frames still '
                                           'arrive; this drive keeps its last references without a master: sending '
                                           'its stop by PDO and SDO until it is at rest or gone')
        return True

    def at_rest(self, node: NodeRuntime) -> None:
        if self._finish(node, 'at rest: stop no longer sent'):
            self._done.add(node.node_id)

    def sdo_due(self, node: NodeRuntime) -> bool:
        """The SDO stop is due (supervisor thread): only while the node is still lost (once it is
        back, it is configured again and its driver owns its outputs)."""
        if node.boot_state is not BootState.LOST:
            return False
        stopping = self._stopping.get(node.node_id)
        now = time.monotonic()
        if stopping is None or now - stopping.last_sdo < SDO_PERIOD:
            return False
        stopping.last_sdo = now
        return True

    def sdo_failed(self, node: NodeRuntime, exc: Exception) -> None:
        stopping = self._stopping.get(node.node_id)
        if stopping is not None and not stopping.sdo_failed:
            stopping.sdo_failed = True
            self.report(node, 'warn', f'node {node.node_id} ({node.name}): the stop by SDO failed ({exc}); '
                                      'still sent by PDO every cycle, and by SDO again')

    def _finish(self, node: NodeRuntime, why: str) -> bool:
        """End the node's stop (reporting ``why`` if given); whether it was being sent."""
        stopping = self._stopping.pop(node.node_id, None)
        if stopping is not None and why:
            self.report(node, 'warn', f'node {node.node_id} ({node.name}): {why} '
                                      f'(after {time.time() - stopping.since:.2f} s)')
        return stopping is not None
