"""The SYNC producer and the bridge's cycle.

The bridge sends SYNC from its own thread rather than python-can's periodic task:
on every interface but SocketCAN that task is a Python thread which, after a stall,
sends the missed SYNCs back to back (measured in docs/python-ecosystem.md §1.3), and
drives latch setpoints on each SYNC. The cycle follows the standard CANopen timing
(as lely does): SYNC goes out first, on its deadline; then the cycle waits (up to half
a period) for the synchronous TPDOs the drives answer it with, so set-points are
decided on fresh feedback; then the ``before_sync`` hooks send the RPDOs for the *next*
SYNC, sampled at that SYNC's grid time, inside the synchronous window; then the
``after_sync`` hooks. Work before the SYNC frame no longer delays it (measured in
docs/performance.md). Deadlines are absolute; a missed deadline is skipped and
counted, never made up with a burst.

With a synchronous window (0x1007 on the drives) a drive discards synchronous RPDOs received
later than the window after SYNC: the RPDOs for the next SYNC must leave inside it. The
feedback wait then ends at half the window at the latest, and a cycle whose ``before_sync``
hooks would start after the window is skipped and counted (``late_setpoints``): the
set-points are not sent, the next cycle samples its own.
"""
from __future__ import annotations

import math
import statistics
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

SYNC_COB_ID = 0x080

CycleHook = Callable[[int], None]
FeedbackWait = Callable[[float], bool]  # wait up to the given seconds for this cycle's TPDOs
FEEDBACK_WINDOW = 0.5  # of a period after SYNC: the longest wait for the drives' TPDOs


@dataclass(frozen=True)
class SyncStats:
    """Measured SYNC timing over the last window of cycles (seconds)."""

    period: float
    cycles: int
    skipped: int
    interval_median: float
    interval_p99: float
    interval_max: float
    jitter_max: float
    lead_median: float
    lead_max: float
    hook_errors: int
    late_setpoints: int = 0  # cycles whose set-points were not sent: the synchronous window had expired


def _percentile(values: list[float], fraction: float) -> float:
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


class SyncProducer:
    """Runs the cycle: before-SYNC hooks, SYNC frame, after-SYNC hooks."""

    def __init__(self, send: Callable[[int, bytes], None], period: float, *,
                 send_sync: bool = True, window: int = 2000,
                 on_error: Callable[[str], None] | None = None,
                 feedback: FeedbackWait | None = None, sync_window: float | None = None,
                 on_start: Callable[[], None] | None = None) -> None:
        if period <= 0:
            raise ValueError(f'SYNC period must be > 0 s, got {period}')
        self.period = period
        self.send_sync = send_sync
        self._send = send
        self._on_error = on_error
        self._feedback = feedback
        self._on_start = on_start  # called in the cycle thread before its first SYNC
        self.sync_window = sync_window or 0.0  # s after SYNC; 0 = no window
        self._feedback_window = min(FEEDBACK_WINDOW * period, self.sync_window / 2 or math.inf)
        self._at_sync: list[CycleHook] = []
        self._before: list[CycleHook] = []
        self._after: list[CycleHook] = []
        self._intervals: deque[float] = deque(maxlen=window)
        self._leads: deque[float] = deque(maxlen=window)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self.cycles = 0
        self.skipped = 0
        self.hook_errors = 0
        self.late_setpoints = 0
        self.last_sync_time = 0.0
        # epoch time this cycle's SYNC is scheduled for (the period grid, not when the
        # thread woke up): set-points sampled against it are not shifted by wake-up jitter
        self.scheduled_time = 0.0
        self._epoch_offset = time.time() - time.perf_counter()

    def add_at_sync(self, hook: CycleHook) -> None:
        """Hook called with the cycle number right before that cycle's SYNC frame (keep it cheap)."""
        with self._lock:
            self._at_sync = [*self._at_sync, hook]

    def add_before_sync(self, hook: CycleHook) -> None:
        """Hook called with the cycle number to send that cycle's set-points: after the previous
        SYNC (and its TPDOs), before this one; ``scheduled_time`` is this SYNC's grid time."""
        with self._lock:
            self._before = [*self._before, hook]

    def add_after_sync(self, hook: CycleHook) -> None:
        """Hook called with the cycle number right after that cycle's SYNC is sent."""
        with self._lock:
            self._after = [*self._after, hook]

    def remove_hook(self, hook: CycleHook) -> None:
        with self._lock:
            self._at_sync = [h for h in self._at_sync if h is not hook]
            self._before = [h for h in self._before if h is not hook]
            self._after = [h for h in self._after if h is not hook]

    def start(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name='drive_bridge-sync', daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def _call(self, hooks: list[CycleHook], cycle: int) -> None:
        for hook in hooks:
            try:
                hook(cycle)
            except Exception as exc:  # one bad hook must not stop SYNC for everyone
                self.hook_errors += 1
                if self._on_error is not None:
                    self._on_error(f'cycle hook {getattr(hook, "__qualname__", hook)!r} failed: {exc!r}')

    def _prepare(self, deadline: float, cycle: int, sent: float = 0.0) -> None:
        """The set-points for the SYNC due at ``deadline``, sampled at its grid time; none when
        the synchronous window of the SYNC sent at ``sent`` has expired (the drives would discard them)."""
        self.scheduled_time = deadline + self._epoch_offset
        if self.sync_window and sent and time.perf_counter() - sent > self.sync_window:
            self.late_setpoints += 1
            return
        if self._before:
            self._call(self._before, cycle)
            self._prepared = time.perf_counter()

    def _run(self) -> None:
        if self._on_start is not None:
            self._on_start()
        period = self.period
        deadline = time.perf_counter() + period
        previous = 0.0
        self._prepared = 0.0
        self._prepare(deadline, self.cycles)
        while not self._stop.is_set():
            delay = deadline - time.perf_counter()
            if delay > 0 and self._stop.wait(delay):
                break
            cycle = self.cycles
            if self._at_sync:
                self._call(self._at_sync, cycle)
            if self.send_sync:
                try:
                    self._send(SYNC_COB_ID, b'')
                except Exception as exc:
                    self.hook_errors += 1
                    if self._on_error is not None:
                        self._on_error(f'sending SYNC failed: {exc!r}')
            sent = time.perf_counter()
            self.last_sync_time = time.time()
            if previous:
                self._intervals.append(sent - previous)
            if self._prepared:
                self._leads.append(sent - self._prepared)
                self._prepared = 0.0
            previous = sent
            self.cycles += 1
            # stay on the period grid; a grid point closer than half a period to this
            # SYNC (we ran late) is skipped, so drives never see SYNCs back to back
            deadline += period
            while deadline - sent < period / 2:
                deadline += period
                self.skipped += 1
            if self._feedback is not None:
                self._feedback(max(0.0, sent + self._feedback_window - time.perf_counter()))
            self._prepare(deadline, cycle + 1, sent if self.send_sync else 0.0)
            self._call(self._after, cycle)

    def stats(self) -> SyncStats:
        """Timing of the recent window: intervals between SYNCs and setpoint lead."""
        intervals = list(self._intervals)
        leads = list(self._leads)
        return SyncStats(
            period=self.period,
            cycles=self.cycles,
            skipped=self.skipped,
            interval_median=statistics.median(intervals) if intervals else 0.0,
            interval_p99=_percentile(intervals, 0.99),
            interval_max=max(intervals, default=0.0),
            jitter_max=max((abs(x - self.period) for x in intervals), default=0.0),
            lead_median=statistics.median(leads) if leads else 0.0,
            lead_max=max(leads, default=0.0),
            hook_errors=self.hook_errors,
            late_setpoints=self.late_setpoints,
        )
