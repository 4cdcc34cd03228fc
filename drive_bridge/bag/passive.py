"""Passive recording: the frames of a bus the bridge does not own (its master is a PLC).

Only ``recv``: no canopen Network, so nothing is ever sent (no SYNC, NMT, SDO or heartbeat).
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable

import can

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.recorder import Recorder, RecorderStats

RECV_TIMEOUT = 0.1  # s: how soon a stop request is seen
DRAIN_SECONDS = 0.2  # s at most, after a stop request, for the frames already received


def record_passive(bus: can.BusABC, recorder: Recorder, stop: threading.Event, *, duration: float = 0.0,
                   report: Callable[[RecorderStats], None] | None = None, report_period: float = 0.5,
                   name: str = '') -> RecorderStats:
    """Queue every received frame until ``stop`` is set (or ``duration`` s passed), then close the bag.
    Frames the interface received before the stop (waiting in its queue) are still recorded,
    for up to DRAIN_SECONDS on a bus that keeps sending.
    A failing interface (unplugged adapter, interface down) closes the bag and raises BagError
    naming it (``name``, e.g. 'socketcan:can0'; default the bus's channel_info)."""
    deadline = time.monotonic() + duration if duration > 0 else float('inf')
    next_report = time.monotonic() + report_period
    try:
        while not stop.is_set():
            try:
                msg = bus.recv(RECV_TIMEOUT)
            except (can.CanError, OSError) as exc:
                raise BagError(f'CAN interface {name or bus.channel_info}: receive failed: {exc} '
                               f'(the bag {recorder.path} is closed with the frames before)') from exc
            if msg is not None:
                recorder.on_frame(msg)
            now = time.monotonic()
            if now >= deadline:
                break
            if report is not None and now >= next_report:
                report(recorder.stats())
                next_report = now + report_period
        if stop.is_set():
            _drain(bus, recorder)
    finally:
        stats = recorder.stop()
    return stats


def _drain(bus: can.BusABC, recorder: Recorder) -> None:
    """Record what the interface queued before the stop (bounded: the bus may keep sending)."""
    until = time.monotonic() + DRAIN_SECONDS
    try:
        while time.monotonic() < until and (msg := bus.recv(0)) is not None:
            recorder.on_frame(msg)
    except (can.CanError, OSError):  # the interface went away as it stopped: what came is kept
        pass
