"""Per-TPDO freshness: a drive whose process data stops while its heartbeat goes on.

A heartbeat only says the node's communication is alive; a drive can still stop sending a
TPDO (a lost SYNC consumer, a reconfigured PDO, a stuck application). The watchdog knows
when each TPDO is due (every n-th SYNC, or its event timer) and is polled by the
supervisor: it reads the receive counters the Notifier already keeps, so the frame path
gets no extra work. A synchronous TPDO is judged by the SYNCs sent since its last frame,
not by the clock alone: when the master's own cycle stalls, no drive is blamed for it.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from drive_bridge.master.pdo import PdoLayout

FRESHNESS_PERIODS = 50  # a TPDO is stale after this many of its periods without a frame...
FRESHNESS_MIN = 0.25  # ...but never sooner than this (s): scheduling noise is not a fault
SYNC_TRANSMISSION = range(1, 241)  # transmission types 1..240: every n-th SYNC
EVENT_TRANSMISSION = (254, 255)


def expected_period(layout: PdoLayout, sync_period: float) -> float | None:
    """Seconds between two frames of this TPDO, None when it is sent only on change."""
    pdo = layout.config
    if pdo.transmission in SYNC_TRANSMISSION and sync_period > 0:
        return pdo.transmission * sync_period
    if pdo.transmission in EVENT_TRANSMISSION and pdo.event_timer > 0:
        return pdo.event_timer / 1000.0
    return None


@dataclass(frozen=True)
class StalePdo:
    """A TPDO overdue: which, for how long, and what was expected."""

    number: int
    cob_id: int
    age: float
    period: float
    limit: float

    def __str__(self) -> str:
        return (f'TPDO{self.number} 0x{self.cob_id:03X} stale: none for {self.age * 1000:.0f} ms '
                f'(expected every {self.period * 1000:.0f} ms, limit {self.limit * 1000:.0f} ms)')


class PdoFreshness:
    """Deadlines of one node's cyclic TPDOs; ``arm`` when the node starts, ``poll`` each
    supervision period (one thread)."""

    def __init__(self, layouts: Mapping[int, PdoLayout], counts: Mapping[int, int], sync_period: float) -> None:
        self._counts = counts  # the ProcessImage's receive counters, by COB-ID (read only)
        self._watched: dict[int, tuple[PdoLayout, float, float, int]] = {}
        for cob_id, layout in layouts.items():
            period = expected_period(layout, sync_period)
            if period is not None:
                syncs = FRESHNESS_PERIODS * layout.config.transmission \
                    if layout.config.transmission in SYNC_TRANSMISSION else 0
                self._watched[cob_id] = (layout, period, max(FRESHNESS_PERIODS * period, FRESHNESS_MIN), syncs)
        # cob -> (receive count, monotonic time and SYNC count when it last changed)
        self._seen: dict[int, tuple[int, float, int]] = {}

    @property
    def watched(self) -> tuple[int, ...]:
        return tuple(self._watched)

    def arm(self, now: float, syncs: int = 0) -> None:
        """Start the clocks (the node was just started: its TPDOs are due from now on)."""
        self._seen = {cob: (self._counts.get(cob, 0), now, syncs) for cob in self._watched}

    def poll(self, now: float, syncs: int = 0) -> list[StalePdo]:
        """The TPDOs overdue now (empty when all are fresh or the watchdog is not armed);
        ``syncs``: the SYNCs sent so far."""
        stale = []
        for cob_id, (count, since, since_sync) in list(self._seen.items()):
            current = self._counts.get(cob_id, 0)
            if current != count:
                self._seen[cob_id] = (current, now, syncs)
                continue
            layout, period, limit, sync_limit = self._watched[cob_id]
            if now - since > limit and syncs - since_sync >= sync_limit:
                stale.append(StalePdo(layout.config.number, cob_id, now - since, period, limit))
        return stale
