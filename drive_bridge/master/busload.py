"""Counting frames and estimating bus load from what the tap sees."""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import can

from drive_bridge.cia301.busbits import frame_bits as bits_of


def frame_bits(msg: can.Message) -> int:
    """Nominal bits on the wire (no stuff bits): 47 + 8 per data byte (docs/python-ecosystem.md §5)."""
    return bits_of(len(msg.data), msg.is_extended_id, msg.is_remote_frame)


@dataclass(frozen=True)
class BusTraffic:
    rx_frames: int
    tx_frames: int
    frames_per_second: float  # over the last window
    load: float  # fraction of the bit rate over the last window (nominal, no stuffing)


class TrafficCounter:
    """A tap listener: totals, and rate/load over windows of about one second."""

    def __init__(self, bitrate: int | None, window: float = 1.0) -> None:
        self.bitrate = bitrate or 0
        self.window = window
        self.rx = self.tx = 0
        self._bits = self._frames = 0
        self._since = time.monotonic()
        self._rate = self._load = 0.0
        self._lock = threading.Lock()

    def __call__(self, msg: can.Message) -> None:
        with self._lock:
            if msg.is_rx:
                self.rx += 1
            else:
                self.tx += 1
            self._frames += 1
            self._bits += frame_bits(msg)
            self._roll(time.monotonic())

    def _roll(self, now: float) -> None:
        elapsed = now - self._since
        if elapsed >= self.window:
            self._rate = self._frames / elapsed
            self._load = self._bits / elapsed / self.bitrate if self.bitrate else 0.0
            self._frames = self._bits = 0
            self._since = now

    def traffic(self) -> BusTraffic:
        with self._lock:
            self._roll(time.monotonic())
            return BusTraffic(self.rx, self.tx, self._rate, self._load)
