"""A bounded thread pool for the requests that wait on the bus: a client may ask as often as
it likes, and a plain pool would queue its work without end. Beyond ``limit`` requests
running or waiting, :meth:`Workers.submit` raises :class:`Busy` at once."""
from __future__ import annotations

import concurrent.futures
import threading
from collections.abc import Callable

from drive_bridge.busproc.errors import Busy


class Workers:
    def __init__(self, workers: int, limit: int, name: str) -> None:
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=workers, thread_name_prefix=name)
        self.limit = limit
        self._pending = 0
        self._lock = threading.Lock()

    def submit(self, work: Callable[[], None]) -> None:
        with self._lock:
            if self._pending >= self.limit:
                raise Busy(f'busy: {self._pending} requests are already running or waiting in the bus process '
                           f'(at most {self.limit}); nothing was sent, try again once they are answered')
            self._pending += 1

        def run() -> None:
            try:
                work()
            finally:
                with self._lock:
                    self._pending -= 1
        try:
            self._pool.submit(run)
        except RuntimeError as exc:  # shut down
            with self._lock:
                self._pending -= 1
            raise Busy(f'the bus process is shutting down: {exc}') from None

    def shutdown(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
