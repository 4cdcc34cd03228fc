"""Heartbeat and node guarding (error-control frames 0x700 + node): periods learned from the
trace (or the configured / SDO-written producer time), gaps, stops, unanswered guarding
requests and toggle-bit errors."""
from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from drive_bridge.bag.diagnose.model import Context, Severity
from drive_bridge.bag.diagnose.nmt import STATES, NmtTimeline

GAP_FACTOR = 2.0  # an interval over twice the period (plus the trace's time resolution) is a gap
RESOLUTION_S = 0.02
CONSUMER_FACTOR = 3.0  # a gap this long trips a usual heartbeat consumer (1.5..3 x the period)


@dataclass
class NodeLiveness:
    heartbeats: list[float] = field(default_factory=list)
    last_state: int | None = None
    producer_ms: int = 0  # from the config or a 0x1017 write in the trace
    guard_requests: list[float] = field(default_factory=list)
    guard_replies: int = 0
    reply_times: list[float] = field(default_factory=list)
    guard_pending: float | None = None
    unanswered: list[float] = field(default_factory=list)
    toggle_errors: list[float] = field(default_factory=list)
    last_toggle: int | None = None
    last_reply: float = -1.0
    period: float | None = None  # learned (s)
    guard_period: float | None = None
    gaps: list[tuple[float, float, bool]] = field(default_factory=list)  # (start, end, rebooted) relative


def median(values: Iterable[float]) -> float:
    """statistics.median, to the bit (the mean of the middle two of an even count), without
    importing statistics (random, fractions, decimal: a noticeable part of a short run's start)."""
    ordered = sorted(values)
    half = len(ordered) // 2
    return ordered[half] if len(ordered) % 2 else (ordered[half - 1] + ordered[half]) / 2


class Liveness:
    def __init__(self, ctx: Context, nmt: NmtTimeline, seen: Callable[[int], int]) -> None:
        self.ctx = ctx
        self.seen = seen  # frames from the node so far (the boot-up included)
        self.nmt = nmt
        self.nodes: dict[int, NodeLiveness] = {}

    def node(self, node: int) -> NodeLiveness:
        live = self.nodes.get(node)
        if live is None:
            info = self.ctx.nodes.get(node)
            live = self.nodes[node] = NodeLiveness(producer_ms=info.heartbeat_ms if info else 0)
        return live

    def frame(self, t: float, cob: int, data: bytes | bytearray, remote: bool = False) -> None:
        """An error-control frame (0x700 + node): the engine's handler for its COB-IDs."""
        node = cob - 0x700
        self.ctx.events += 1
        live = self.nodes.get(node) or self.node(node)
        if remote:
            if live.guard_pending is not None:
                live.unanswered.append(live.guard_pending)
            live.guard_requests.append(t)
            live.guard_pending = t
            return
        if not data:
            return
        b0 = data[0]
        state = b0 & 0x7F
        if b0 == 0:
            last_alive = max(live.heartbeats[-1] if live.heartbeats else -1.0, live.last_reply)
            live.last_toggle = None  # the toggle restarts at 0 after a boot-up
            live.last_state = 0
            live.heartbeats.append(t)
            self.nmt.boot_up(t, node, self.seen(node) > 1, last_alive if last_alive >= 0 else None)
            return
        if live.guard_pending is not None:
            toggle = b0 & 0x80
            if live.last_toggle is not None and toggle == live.last_toggle:
                live.toggle_errors.append(t)
            live.last_toggle = toggle
            live.guard_pending = None
            live.guard_replies += 1
            live.last_reply = t
            live.reply_times.append(t)
        else:
            live.heartbeats.append(t)
        self.ctx.states[node] = state
        if state != live.last_state:
            live.last_state = state
            self.nmt.state(t, node, f'NMT state {STATES.get(state, f"0x{state:02X} (invalid)")}')

    def finish(self, end: float) -> None:
        for node, live in sorted(self.nodes.items()):
            self._heartbeat(node, live, end)
            self._guarding(node, live)

    def _heartbeat(self, node: int, live: NodeLiveness, end: float) -> None:
        if not self.ctx.timing:
            return
        beats = live.heartbeats
        boots = set(self.nmt.boot_ups.get(node, []))
        # after a boot-up the producer may be off until the master writes 0x1017: no gap
        pairs = [(a, b) for a, b in zip(beats, beats[1:]) if a not in boots]
        intervals = [b - a for a, b in pairs]
        if len(intervals) < 2:
            return
        learned = median(intervals)
        live.period = learned
        period = live.producer_ms / 1000 if live.producer_ms else learned
        limit = GAP_FACTOR * period + RESOLUTION_S
        t0 = self.ctx.t0
        for a, b in pairs:
            if b - a <= limit:
                continue
            rebooted = b in boots
            live.gaps.append((a - t0, b - t0, rebooted))
            if self.nmt.reset_between(node, a, b):
                continue  # the master reset the node: its boot-up is in the timeline
            if rebooted:
                self.ctx.add(Severity.ERROR, a, node, f'heartbeat missing {b - a:.2f} s, then boot-up',
                             'the drive rebooted', 'heartbeat-gap')
            else:
                severity = Severity.ERROR if b - a >= CONSUMER_FACTOR * period else Severity.WARNING
                self.ctx.add(severity, a, node,
                             f'heartbeat missing {b - a:.2f} s (period {period * 1000:.0f} ms)',
                             'the node stopped producing and came back without a reboot: '
                             'bus errors, a loose cable, or the node was overloaded', 'heartbeat-gap')
        if end - beats[-1] > limit + period and len(beats) >= 3:
            self.ctx.add(Severity.ERROR, beats[-1], node,
                         f'heartbeat stopped: none for the last {end - beats[-1]:.2f} s of the recording',
                         'the node went off the bus (power, cable) or hung', 'heartbeat-stopped')

    def _guarding(self, node: int, live: NodeLiveness) -> None:
        requests = live.guard_requests
        if len(requests) >= 3:
            live.guard_period = median(b - a for a, b in zip(requests, requests[1:]))
        for times, what, cause, kind in (
                (live.unanswered, 'node guarding request(s) unanswered',
                 'the node is absent or not guarded (0x100C/0x100D not set)', 'guarding-unanswered'),
                (live.toggle_errors, 'node guarding reply toggle bit did not alternate',
                 'a reply was lost or repeated (CiA 301 §7.2.8.3.2.1)', 'guarding-toggle')):
            if times:
                span = f' from t={times[0] - self.ctx.t0:.3f} s to t={times[-1] - self.ctx.t0:.3f} s' \
                    if len(times) > 1 else ''
                self.ctx.add(Severity.WARNING, times[0], node, f'{len(times)} {what}{span}', cause, kind)
