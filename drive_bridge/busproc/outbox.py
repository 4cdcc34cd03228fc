"""The bus process's outgoing side: one sender thread, fed by bounded queues, so that no bus
thread (the cycle, the CAN receive thread, supervision) ever waits for the node process.

- Records (answers, events, EMCY, handle changes) queue in :attr:`Outbox.records`, at most
  :data:`MAX_RECORDS`; beyond that a new record that is not an answer is dropped and counted
  (answers always go: a request waits for its own, and there are as many as requests in flight).
  The count crosses in every cyclic state's header (:mod:`.cyclic`: not this lane, which is the
  one that is full), and the first drop is logged here.
- Axis snapshots are not queued: the cycle marks a joint changed (a cheap ``state_key``
  compare) and the sender builds and sends the snapshots of the marked joints.
- Frames for recording queue as python-can messages (:meth:`on_frame`, a tap listener: one
  ``deque.append``), at most :data:`MAX_FRAMES`; the sender packs them in batches of
  ``reports.FRAMES_PER_BATCH``. A full queue drops frames and counts them; the count travels
  with every batch (recording puts it in the bag's metadata and in /diagnostics).
"""
from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping

import can

from drive_bridge.busproc import wire
from drive_bridge.busproc.reports import FRAMES_PER_BATCH, AxisStates, Failure, FrameFields, Frames, Reply, pack_frames
from drive_bridge.joint import JointDriver

log = logging.getLogger('drive_bridge.busproc')

MAX_RECORDS = 10_000
MAX_FRAMES = 100_000  # ~5 s at 20,000 frames/s
IDLE_WAIT = 0.01  # s the sender sleeps with nothing to send (frames wait at most this long)
REFRESH = 1.0  # s between two full sets of axis snapshots (the node's view never goes stale)


class Outbox:
    def __init__(self, lane: wire.Lane, on_lost: Callable[[str], None]) -> None:
        self.lane = lane
        self.axes: dict[str, JointDriver] = {}
        self._on_lost = on_lost
        self.records: deque[object] = deque()
        self.frames: deque[can.Message] = deque()
        self.forward_frames = False
        self.dropped_records = 0
        self.dropped_frames = 0
        self._keys: dict[str, tuple[object, ...]] = {}
        self._changed: set[str] = set()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name='drive_bridge-outbox', daemon=True)

    def watch_axes(self, axes: Mapping[str, JointDriver]) -> None:
        """The axes whose snapshots are sent when their state changes (once the master started)."""
        self.axes = dict(axes)
        self._keys = {joint: _key(axis) for joint, axis in self.axes.items()}
        self._changed = set(self.axes)

    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout: float = 1.0) -> None:
        """Send what is queued (bounded wait), then end the thread."""
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(timeout)

    # -- producers (any thread; keep them short) ----------------------------------------------
    def put(self, record: object) -> None:
        if len(self.records) >= MAX_RECORDS and not isinstance(record, Reply | Failure):
            self.dropped_records += 1
            if self.dropped_records == 1:
                log.warning('outbox full (%d records): reports to the node are dropped (first: %s); '
                            'the count shows on /diagnostics', MAX_RECORDS, type(record).__name__)
            return
        self.records.append(record)
        self._wake.set()

    def on_frame(self, msg: can.Message) -> None:
        """Frame tap listener (bus threads, the cycle's among them)."""
        if not self.forward_frames:
            return
        if len(self.frames) < MAX_FRAMES:
            self.frames.append(msg)
        else:
            self.dropped_frames += 1

    def check_axes(self) -> None:
        """Cycle hook: mark the joints whose reported state changed (no snapshot built here)."""
        changed = False
        for joint, axis in self.axes.items():
            key = _key(axis)
            if key != self._keys[joint]:
                self._keys[joint] = key
                self._changed.add(joint)
                changed = True
        if changed:
            self._wake.set()

    # -- the sender thread ---------------------------------------------------------------------------
    def _run(self) -> None:
        refreshed = 0.0
        try:
            while True:
                self._wake.wait(IDLE_WAIT)
                self._wake.clear()
                now = time.monotonic()
                if now - refreshed >= REFRESH:
                    refreshed = now
                    self._changed.update(self.axes)
                if self._changed:
                    joints, self._changed = self._changed, set()
                    self.lane.send(axis_states([a for j, a in self.axes.items() if j in joints]))
                while self.records:
                    self.lane.send(self.records.popleft())
                self._send_frames()
                if self._stop.is_set() and not self.records:
                    return
        except OSError as exc:  # the node process is gone: its side of the lane closed
            self._on_lost(f'request lane closed ({exc})')
        except Exception:  # never die silently: the node would wait for answers for ever
            log.exception('outbox sender failed')
            self._on_lost('the bus process\'s sender failed')

    def _send_frames(self) -> None:
        frames = self.frames
        while frames:
            batch: list[FrameFields] = []
            while frames and len(batch) < FRAMES_PER_BATCH:
                msg = frames.popleft()
                batch.append((msg.timestamp, msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame,
                              msg.is_error_frame, msg.dlc, bytes(msg.data), msg.is_rx, msg.is_fd))
            data, count = pack_frames(batch)
            self.lane.send(Frames(data, count, self.dropped_frames))


def _key(axis: JointDriver) -> tuple[object, ...]:
    """What the node's view of an axis depends on: its reported state, and the mode the bridge
    requests (the command field and the streaming strategy follow it)."""
    return (*axis.state_key(), axis.mode)


def axis_states(axes: list[JointDriver]) -> AxisStates:
    taken = time.monotonic()  # before reading: a snapshot taken later is at least as new
    return AxisStates(tuple(a.snapshot() for a in axes), tuple(a.command_field() for a in axes),
                      tuple(a.stream_strategy() for a in axes), taken)
