"""Floods of frames: a babbling node's EMCYs, frames nobody on this master listens to.

At a 1 Mbit/s bus's full rate (about 8,000 frames/s) one EMCY per frame would become one
log line, one ROS message and one decoded history entry each: the work must be bounded
where it is cheap, in the Notifier thread. EMCYs pass a per-node token bucket (the
excess is counted, the flood reported once per episode); unknown COB-IDs are counted by
a tap listener and reported by the supervisor at most every REPORT_INTERVAL.
"""
from __future__ import annotations

import threading
from collections.abc import Container

import can

EMCY_RATE = 20.0  # EMCYs per second per node passed on to listeners...
EMCY_BURST = 20  # ...after a burst of this many
UNKNOWN_IDS_KEPT = 32  # distinct unknown COB-IDs counted one by one (the rest only in the total)
REPORT_INTERVAL = 5.0  # s between two reports of unknown frames


class TokenBucket:
    """``allow(now)``: True for at most ``burst`` at once and ``rate`` per second after."""

    def __init__(self, rate: float, burst: int) -> None:
        self.rate = rate
        self.burst = float(burst)
        self._tokens = float(burst)
        self._last = 0.0
        self.suppressed = 0  # calls refused, in total
        self.flooding = False  # refusing since the bucket last refilled to full

    def allow(self, now: float) -> bool:
        if self._last:
            self._tokens = min(self.burst, self._tokens + (now - self._last) * self.rate)
        self._last = now
        if self._tokens >= 1.0:
            self._tokens -= 1.0
            if self._tokens >= self.burst - 1.0:
                self.flooding = False  # a quiet spell ends the episode
            return True
        self.suppressed += 1
        return False


class UnknownFrames:
    """A tap listener counting received frames whose COB-ID no one subscribed to."""

    def __init__(self, known: Container[int]) -> None:
        self._known = known
        self.active = False  # set once every node has subscribed (earlier frames are not unknown)
        self.total = 0
        self.by_id: dict[int, int] = {}
        self._lock = threading.Lock()
        self._reported = 0
        self._last_report = 0.0

    def __call__(self, msg: can.Message) -> None:
        if not self.active or not msg.is_rx or msg.is_error_frame or msg.arbitration_id in self._known:
            return
        with self._lock:
            self.total += 1
            cob = msg.arbitration_id
            if cob in self.by_id or len(self.by_id) < UNKNOWN_IDS_KEPT:
                self.by_id[cob] = self.by_id.get(cob, 0) + 1

    def report(self, now: float) -> str | None:
        """A line about the unknown frames since the last report, at most every REPORT_INTERVAL."""
        with self._lock:
            new = self.total - self._reported
            if not new or (self._last_report and now - self._last_report < REPORT_INTERVAL):
                return None
            self._reported, self._last_report = self.total, now
            top = sorted(self.by_id.items(), key=lambda item: -item[1])[:5]
        ids = ', '.join(f'0x{cob:03X} x{count}' for cob, count in top)
        return (f'{new} frame(s) with COB-IDs no configured node uses ({self.total} in total; most: {ids}); '
                'ignored')
