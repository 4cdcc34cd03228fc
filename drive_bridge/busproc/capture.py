"""A timing capture of the bus in the bus process: (timestamp, COB-ID, sent) of every frame
while it runs, written to a JSON file when it stops. What ``bench ros_cycle`` measures the
cycle by (SYNC intervals, set-points before their SYNC), at the cost of one append per frame:
frames for recording cross the boundary in batches, which would change what is measured."""
from __future__ import annotations

import json
import threading
from array import array
from pathlib import Path

import can


class Capture:
    def __init__(self) -> None:
        self.path = ''
        self._times = array('d')
        self._ids = array('I')
        self._sent = array('b')
        self._lock = threading.Lock()

    def on_frame(self, msg: can.Message) -> None:
        """Frame tap listener (bus threads)."""
        if self.path:
            self._times.append(msg.timestamp)
            self._ids.append(msg.arbitration_id)
            self._sent.append(0 if msg.is_rx else 1)

    def set(self, path: str) -> None:
        """Start capturing for ``path``; '' stops and writes what was captured to the last path."""
        with self._lock:
            previous, self.path = self.path, path
            if path:
                self._times, self._ids, self._sent = array('d'), array('I'), array('b')
                return
            if previous:
                frames = [[t, i, bool(s)] for t, i, s in zip(self._times, self._ids, self._sent)]
                Path(previous).write_text(json.dumps(frames))
