"""Recording the bus: a frame-tap listener that only queues, and a writer thread that writes.

The listener runs in the bus threads (the receive thread, and whichever thread sends: the
SYNC cycle among them), so it does the least possible: one bounded ``deque.append`` and,
when the queue is full, one count of the dropped frame. Encoding and writing happen in
the writer thread, which sleeps between small batches so the cycle thread never waits long
for the GIL. Memory is bounded by ``queue_frames`` (frames and messages queued).
"""
from __future__ import annotations

import os
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.writer import BagWriter
from drive_bridge.model import BusConfig

QUEUE_FRAMES = 100_000   # ~5 s at 20,000 frames/s, ~40 MB of can.Message at most
BATCH = 64               # items written between GIL releases (~0.5 ms of work)
YIELD_SLEEP = 0.0005     # s the writer sleeps between batches: long enough for a waiting thread to take
                         # the GIL (a bare sleep(0) lets the writer take it straight back, and the cycle
                         # thread would wait out the 5 ms switch interval); capacity ~60,000 frames/s
IDLE_SLEEP = 0.005       # s, writer thread with an empty queue
FLUSH_SECONDS = 1.0      # a killed recorder loses about this much of the open split


@dataclass(frozen=True)
class RecorderStats:
    """What the recorder reports (in /diagnostics, the service answer and the CLI)."""

    path: Path
    frames: int           # CAN frames written
    messages: int         # other messages written (decoded topics, stored files)
    dropped: int          # frames and messages lost: the queue was full, or a CAN FD frame
    queued: int
    bytes: int            # written, before compression
    split: str            # file name of the open split
    splits: int           # closed splits
    running: bool
    error: str            # why the writer stopped, '' when it did not fail
    dropped_fd: int = 0   # of ``dropped``: CAN FD frames (a bag's CanFrame holds classic frames only)
    dropped_upstream: int = 0  # frames lost before they reached the recorder (the bus process's queue)

    def summary(self) -> str:
        fd = f' ({self.dropped_fd} CAN FD frames: a bag holds classic CAN only)' if self.dropped_fd else ''
        upstream = f', {self.dropped_upstream} lost before the recorder' if self.dropped_upstream else ''
        return (f'{self.path}: {self.frames} frames, {self.messages} messages, {self.dropped} dropped{fd}{upstream}, '
                f'{self.bytes / 1e6:.1f} MB in {self.splits + (1 if self.split else 0)} split(s)'
                + (f'; error: {self.error}' if self.error else ''))


Message = tuple[str, str, int, Any, Callable[[Any], bytes] | None]


class Recorder:
    """Records frames (``on_frame``, a tap listener) and raw-CDR messages (``add_message``)."""

    def __init__(self, path: Path, *, channel: str = '', split_bytes: int | None = None,
                 split_seconds: float | None = None, config_yaml: str | None = None,
                 files: Mapping[str, bytes] = {}, queue_frames: int = QUEUE_FRAMES,
                 upstream_drops: Callable[[], int] | None = None) -> None:
        """``upstream_drops``: how many frames were lost before they reached this recorder so far
        (kept in metadata.yaml's custom_data as ``frames_dropped_upstream``)."""
        self.writer = BagWriter(path, split_bytes=split_bytes, split_seconds=split_seconds,
                                config_yaml=config_yaml, files=files)
        self.path = self.writer.path
        self.channel = channel
        self.queue_frames = queue_frames
        self.upstream_drops = upstream_drops
        self._frames: deque[can.Message] = deque()
        self._messages: deque[Message] = deque()
        self.dropped = 0
        self.dropped_fd = 0
        self._drop_lock = threading.Lock()  # listeners run in several threads; drops are rare
        self._accepting = True
        self._stop = threading.Event()
        self.error = ''
        self._thread = threading.Thread(target=self._run, name='drive_bridge-recorder', daemon=True)
        self._thread.start()

    # -- producers (any thread, keep them short) ------------------------------------------------
    def on_frame(self, msg: can.Message) -> None:
        """Tap listener: queue the frame (python-can makes a new Message per frame)."""
        if msg.is_fd:  # CanFrame has no FD fields: it would replay as a wrong classic frame
            with self._drop_lock:
                self.dropped += 1
                self.dropped_fd += 1
        elif self._accepting and len(self._frames) + len(self._messages) < self.queue_frames:
            self._frames.append(msg)
        else:
            self._drop()

    def add_message(self, topic: str, msgtype: str, timestamp_ns: int, cdr: Any,
                    serialize: Callable[[Any], bytes] | None = None) -> None:
        """A decoded topic's message on the bag's timeline: raw CDR, or a message object that
        ``serialize`` turns into CDR in the writer thread (not in the caller's, e.g. the cycle thread).
        The object must not change after it is queued (a published message does not)."""
        if self._accepting and len(self._frames) + len(self._messages) < self.queue_frames:
            self._messages.append((topic, msgtype, timestamp_ns, cdr, serialize))
        else:
            self._drop()

    def _drop(self) -> None:
        with self._drop_lock:
            self.dropped += 1

    # -- writer thread ------------------------------------------------------------------------------
    def _run(self) -> None:
        writer = self.writer
        frames, messages = self._frames, self._messages
        last_flush = time.monotonic()
        try:
            while True:
                idle = True
                for _ in range(BATCH):
                    if not frames:
                        break
                    writer.write_frame(frames.popleft(), self.channel)
                    idle = False
                for _ in range(BATCH):
                    if not messages:
                        break
                    topic, msgtype, stamp, data, serialize = messages.popleft()
                    writer.write(topic, msgtype, stamp, serialize(data) if serialize is not None else data)
                    idle = False
                now = time.monotonic()
                if self.upstream_drops is not None:  # in the metadata written at each closed split
                    writer.custom['frames_dropped_upstream'] = str(self.upstream_drops())
                if now - last_flush >= FLUSH_SECONDS:
                    writer.flush()
                    last_flush = now
                if idle:
                    if self._stop.is_set():
                        break
                    time.sleep(IDLE_SLEEP)
                else:
                    time.sleep(YIELD_SLEEP)
        except Exception as exc:  # disk full, permissions...: stop recording, report it
            self.error = f'{type(exc).__name__}: {exc}'
            self._accepting = False
            with self._drop_lock:
                self.dropped += len(frames) + len(messages)
            frames.clear()
            messages.clear()
        finally:
            try:
                writer.close()
            except Exception as exc:
                self.error = self.error or f'closing the bag: {exc}'

    def stop(self, timeout: float = 30.0) -> RecorderStats:
        """Write what is queued, close the bag, and return the final counts."""
        self._accepting = False  # nothing more in: the drain ends
        self._stop.set()
        self._thread.join(timeout)
        if self._thread.is_alive():
            self.error = self.error or f'writer thread did not finish within {timeout} s'
        return self.stats()

    @property
    def running(self) -> bool:
        return self._thread.is_alive() and not self._stop.is_set()

    def stats(self) -> RecorderStats:
        writer = self.writer
        split = writer.current_split
        return RecorderStats(
            path=self.path, frames=writer.frames, messages=writer.messages - writer.frames,
            dropped=self.dropped, queued=len(self._frames) + len(self._messages), bytes=writer.bytes_written,
            split=split.name if split else '', splits=len(writer.splits), running=self.running, error=self.error,
            dropped_fd=self.dropped_fd,
            dropped_upstream=self.upstream_drops() if self.upstream_drops is not None else 0)


def config_files(config: BusConfig) -> dict[str, bytes]:
    """The EDS/DCF files of the config's nodes, by their path relative to the config's directory
    (as the config names them), else by file name (e.g. a family's shipped EDS)."""
    base = os.path.abspath(config.path.parent if config.path is not None else Path.cwd())
    package = Path(__file__).resolve().parents[1]
    files: dict[str, bytes] = {}
    for node in config.nodes:
        if node.eds_path is None:
            continue
        path = node.eds_path
        name = path.name
        if not path.resolve().is_relative_to(package):  # the config's own path: '../../shared/x.dcf'
            name = Path(os.path.relpath(os.path.abspath(path), base)).as_posix()  # symlinks as the OS reads
        try:
            files[name] = path.read_bytes()
        except OSError as exc:
            raise BagError(f'{path}: cannot read the EDS/DCF of node {node.name!r} to store it: {exc}') from exc
    return files
