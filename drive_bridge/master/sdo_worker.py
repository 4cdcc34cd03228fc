"""Process data that is not in a PDO, carried by SDO from a worker thread.

An axis writes its controlword and reads its statusword the same way whether they are
mapped or not: unmapped outputs are queued here (the newest value per object wins) and
unmapped inputs are polled at a fixed rate. The cycle thread never waits on an SDO.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable

from drive_bridge.master.errors import SdoError
from drive_bridge.master.pdo import ObjectKey
from drive_bridge.master.sdo import SdoChannel

InputSink = Callable[[ObjectKey, int | float, float], None]


class SdoWorker:
    """One thread per node, started on first use."""

    def __init__(self, channel: SdoChannel, sink: InputSink, poll_period: float = 0.01,
                 on_error: Callable[[str], None] | None = None) -> None:
        self.channel = channel
        self.poll_period = poll_period
        self._sink = sink
        self._on_error = on_error
        self._writes: dict[ObjectKey, int | float] = {}
        self._polled: list[ObjectKey] = []
        self._wake = threading.Condition()
        self._thread: threading.Thread | None = None
        self._stop = False
        self._failing: set[ObjectKey] = set()  # reported once, until it succeeds again
        self.failures = 0  # failed SDO accesses of this worker, reported or not
        self.enabled = False  # only while the node is operational

    def write(self, key: ObjectKey, value: int | float) -> None:
        with self._wake:
            self._writes.pop(key, None)  # re-queue at the end: writes keep their order
            self._writes[key] = value
            self._ensure_running()
            self._wake.notify()

    def poll(self, key: ObjectKey) -> None:
        with self._wake:
            if key not in self._polled:
                self._polled.append(key)
            self._ensure_running()

    def _ensure_running(self) -> None:
        if self._thread is None and not self._stop:
            self._thread = threading.Thread(target=self._run, daemon=True,
                                            name=f'drive_bridge-sdo-{self.channel.node.id}')
            self._thread.start()

    def stop(self) -> None:
        with self._wake:
            self._stop = True
            self._wake.notify()
        if self._thread is not None:
            self._thread.join(timeout=2)

    def _report(self, key: ObjectKey, exc: SdoError) -> None:
        """A failure is reported once per object until that object succeeds again (a polled
        input the drive refuses fails at the poll rate); every failure is counted."""
        self.failures += 1
        if key in self._failing:
            return
        self._failing.add(key)
        if self._on_error is not None:
            self._on_error(f'{exc} (reported once until it succeeds again)')

    def _run(self) -> None:
        next_poll = time.monotonic()
        while True:
            with self._wake:
                while not self._stop and not (self.enabled and (self._writes or (
                        self._polled and time.monotonic() >= next_poll))):
                    timeout = max(0.0, next_poll - time.monotonic()) if self._polled else None
                    self._wake.wait(timeout if self.enabled else 0.05)
                if self._stop:
                    return
                writes = list(self._writes.items())
                self._writes.clear()
                polled = list(self._polled) if time.monotonic() >= next_poll else []
            for (index, subindex), value in writes:
                try:
                    self.channel.write(index, subindex, value)
                except SdoError as exc:
                    self._report((index, subindex), exc)
                    continue
                self._failing.discard((index, subindex))
            if polled:
                next_poll = time.monotonic() + self.poll_period
                for key in polled:
                    try:
                        _type, polled_value, _raw = self.channel.read(*key)
                    except SdoError as exc:
                        self._report(key, exc)
                        continue
                    self._failing.discard(key)
                    if isinstance(polled_value, (int, float)):  # process data: numbers only
                        self._sink(key, polled_value, time.time())
