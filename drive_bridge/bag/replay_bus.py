"""Replay recorded frames onto a CAN bus with their original timing.

Not ``can.MessageSync``: it runs slow and its skip still waits. Each frame's send time is
fixed on an absolute schedule (first frame + recorded offset / speed, so errors never add
up) and reached with a sleep to just before it, then a short spin on ``perf_counter``.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass

import can
import numpy as np

from drive_bridge.bag.errors import BagError

SPIN = 0.0015  # s before a frame's time: sleep up to here, then spin (sleep overshoots ~0.1-1 ms)
SEND_TIMEOUT = 0.05  # s a real interface may block on a full transmit queue before a frame counts as lost
NMT_COB_ID = 0x000
SYNC_COB_ID = 0x080
TIME_COB_ID = 0x100


def node_of(msg: can.Message) -> int | None:
    """The node a frame is from or to (CiA 301 predefined connection set), None for a broadcast."""
    cob_id = msg.arbitration_id
    if msg.is_extended_id:
        return None
    if cob_id == NMT_COB_ID:
        return msg.data[1] if len(msg.data) >= 2 and msg.data[1] else None
    if cob_id in (SYNC_COB_ID, TIME_COB_ID):
        return None
    return cob_id & 0x7F or None


def frame_filter(nodes: Collection[int] = (), direction: str | None = None) -> Callable[[can.Message], bool]:
    """Keep the frames of ``nodes`` (none given: all) going ``direction``: 'rx' = frames the
    recording master received (the nodes' side), 'tx' = frames it sent."""
    if direction not in (None, 'rx', 'tx'):
        raise BagError(f"replay direction {direction!r}: expected 'rx' or 'tx'")
    wanted = frozenset(nodes)
    want_rx = None if direction is None else direction == 'rx'

    def keep(msg: can.Message) -> bool:
        if msg.is_error_frame:
            return False
        if want_rx is not None and bool(msg.is_rx) != want_rx:
            return False
        return not wanted or node_of(msg) in wanted
    return keep


@dataclass(frozen=True)
class PacingStats:
    """How closely the replay kept the recorded timing."""

    sent: int
    skipped: int  # filtered out
    send_errors: int
    duration: float  # s, first to last frame sent
    recorded_duration: float  # s, first to last selected frame as recorded
    interval_error_p50: float  # s, |sent interval - recorded interval / speed|
    interval_error_p99: float
    interval_error_max: float
    lateness_max: float  # s, worst send time after the frame's scheduled time

    def lines(self) -> list[str]:
        return [f'frames sent       {self.sent} ({self.skipped} filtered out, {self.send_errors} send errors)',
                f'duration          {self.duration:.3f} s (recorded {self.recorded_duration:.3f} s)',
                f'inter-frame error p50 {self.interval_error_p50 * 1e6:.0f} us, '
                f'p99 {self.interval_error_p99 * 1e6:.0f} us, max {self.interval_error_max * 1e6:.0f} us',
                f'latest frame      {self.lateness_max * 1e6:.0f} us after its time']


def wait_until(deadline: float) -> None:
    """Sleep until just before ``deadline`` (perf_counter), then spin to it."""
    remaining = deadline - time.perf_counter()
    if remaining > SPIN:
        time.sleep(remaining - SPIN)
    while time.perf_counter() < deadline:
        pass


def outgoing(msg: can.Message) -> can.Message:
    """The frame to send: same id, flags and data; the bus stamps it."""
    return can.Message(arbitration_id=msg.arbitration_id, is_extended_id=msg.is_extended_id,
                       is_remote_frame=msg.is_remote_frame, is_fd=msg.is_fd, bitrate_switch=msg.bitrate_switch,
                       dlc=msg.dlc, data=bytes(msg.data))


def replay_onto(frames: Iterable[can.Message], bus: can.BusABC, *, speed: float = 1.0,
                keep: Callable[[can.Message], bool] = lambda _msg: True,
                on_frame: Callable[[], None] | None = None) -> PacingStats:
    """Send the kept frames in order at their recorded offsets / ``speed``."""
    if not speed > 0:
        raise BagError(f'replay speed {speed}: must be > 0')
    first: float | None = None
    start = 0.0
    recorded: list[float] = []
    sent_at: list[float] = []
    skipped = errors = 0
    lateness = 0.0
    for msg in frames:
        if not keep(msg):
            skipped += 1
            continue
        if first is None:
            first, start = msg.timestamp, time.perf_counter()
        deadline = start + (msg.timestamp - first) / speed
        wait_until(deadline)
        try:
            bus.send(outgoing(msg), timeout=SEND_TIMEOUT)
        except can.CanError:
            errors += 1
        now = time.perf_counter()
        lateness = max(lateness, now - deadline)
        recorded.append(msg.timestamp)
        sent_at.append(now)
        if on_frame is not None:
            on_frame()
    return pacing_stats(np.array(recorded), np.array(sent_at), speed, skipped, errors, lateness)


def pacing_stats(recorded: np.ndarray, sent_at: np.ndarray, speed: float, skipped: int, errors: int,
                 lateness: float) -> PacingStats:
    if len(recorded) < 2:
        return PacingStats(len(recorded), skipped, errors, 0.0, 0.0, 0.0, 0.0, 0.0, lateness)
    error = np.abs(np.diff(sent_at) - np.diff(recorded) / speed)
    return PacingStats(len(recorded), skipped, errors, float(sent_at[-1] - sent_at[0]),
                       float(recorded[-1] - recorded[0]), float(np.percentile(error, 50)),
                       float(np.percentile(error, 99)), float(error.max()), lateness)
