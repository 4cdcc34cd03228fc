"""One deadline-scheduler thread per simulated slave.

Everything a slave does on its own clock (heartbeat, event timers, inhibit-time
deferrals, delayed SDO responses, the boot delay, the model tick without SYNC) runs
here, so no callback ever sleeps in the CAN Notifier thread (ecosystem doc §1.4) and
a slave costs one thread instead of one python-can periodic task per timer.
"""
from __future__ import annotations

import heapq
import itertools
import logging
import threading
import time
from collections.abc import Callable

logger = logging.getLogger(__name__)

Callback = Callable[[], None]


class TimerHandle:
    """A scheduled call; ``cancel()`` makes it a no-op (cheap: no heap removal)."""

    __slots__ = ('when', 'callback', 'cancelled')

    def __init__(self, when: float, callback: Callback) -> None:
        self.when = when
        self.callback = callback
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class TimerThread:
    """Runs callbacks at ``time.monotonic()`` deadlines, in order, on one daemon thread.

    Callbacks must be short; an exception is logged and the thread keeps running.
    """

    def __init__(self, name: str) -> None:
        self._name = name
        self._heap: list[tuple[float, int, TimerHandle]] = []
        self._seq = itertools.count()
        self._cond = threading.Condition()
        self._thread: threading.Thread | None = None
        self._running = False

    @property
    def running(self) -> bool:
        return self._running

    def start(self) -> None:
        with self._cond:
            if self._running:
                return
            self._running = True
            self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
            self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        """Cancel everything and join the thread (unless called from it)."""
        with self._cond:
            self._running = False
            for _when, _seq, handle in self._heap:
                handle.cancelled = True
            self._heap.clear()
            self._cond.notify_all()
            thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout)

    def call_at(self, when: float, callback: Callback) -> TimerHandle:
        handle = TimerHandle(when, callback)
        with self._cond:
            if not self._running:
                handle.cancelled = True
                return handle
            heapq.heappush(self._heap, (when, next(self._seq), handle))
            if self._heap[0][2] is handle:
                self._cond.notify()
        return handle

    def call_later(self, delay: float, callback: Callback) -> TimerHandle:
        return self.call_at(time.monotonic() + max(0.0, delay), callback)

    def _run(self) -> None:
        while True:
            with self._cond:
                while self._running:
                    if not self._heap:
                        self._cond.wait()
                        continue
                    wait = self._heap[0][0] - time.monotonic()
                    if wait <= 0:
                        break
                    self._cond.wait(wait)
                if not self._running:
                    return
                _when, _seq, handle = heapq.heappop(self._heap)
            if handle.cancelled:
                continue
            try:
                handle.callback()
            except Exception:  # a broken callback must not stop the slave's clock
                logger.exception('%s: timer callback failed', self._name)


class Periodic:
    """A drift-free periodic call on a TimerThread; missed periods are skipped, never bursted.

    ``start``/``stop`` may be called from any thread, also from inside the callback.
    """

    def __init__(self, timers: TimerThread, callback: Callback) -> None:
        self._timers = timers
        self._callback = callback
        self._lock = threading.Lock()
        self._handle: TimerHandle | None = None
        self._generation = 0
        self._period = 0.0
        self._next = 0.0

    @property
    def active(self) -> bool:
        return self._handle is not None

    @property
    def period(self) -> float:
        return self._period if self._handle is not None else 0.0

    def start(self, period: float, first_delay: float | None = None) -> None:
        """(Re)start with ``period`` seconds; the first call after ``first_delay`` (default: one period)."""
        with self._lock:
            self._cancel()
            if period <= 0:
                return
            self._period = period
            self._next = time.monotonic() + (period if first_delay is None else max(0.0, first_delay))
            self._schedule()

    def stop(self) -> None:
        with self._lock:
            self._cancel()

    def _cancel(self) -> None:
        self._generation += 1
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None

    def _schedule(self) -> None:
        generation = self._generation
        self._handle = self._timers.call_at(self._next, lambda: self._fire(generation))

    def _fire(self, generation: int) -> None:
        with self._lock:
            if generation != self._generation:
                return
            now = time.monotonic()
            self._next += self._period
            if self._next <= now:  # late (scheduler stall): skip the missed periods
                self._next = now + self._period
            self._schedule()
        self._callback()
