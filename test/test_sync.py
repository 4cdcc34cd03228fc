"""The SYNC producer: hooks before and after each SYNC, skipping (not bursting) after a stall."""
from __future__ import annotations

import time

from drive_bridge.master.sync import SYNC_COB_ID, SyncProducer


def test_cycle_order_and_no_burst_after_a_stall() -> None:
    log: list[tuple[str, int, float]] = []
    producer = SyncProducer(lambda cob, data: log.append(('sync', cob, time.perf_counter())), 0.005)
    stalled = []

    def before(cycle: int) -> None:
        log.append(('before', cycle, time.perf_counter()))
        if cycle == 20 and not stalled:
            stalled.append(cycle)
            time.sleep(0.05)  # ten periods lost

    producer.add_before_sync(before)
    producer.add_after_sync(lambda cycle: log.append(('after', cycle, time.perf_counter())))
    producer.start()
    time.sleep(0.4)
    producer.stop()
    kinds = [k for k, _, _ in log]
    # every cycle is before -> SYNC -> after
    assert kinds[:6] == ['before', 'sync', 'after', 'before', 'sync', 'after']
    assert all(cob == SYNC_COB_ID for k, cob, _ in log if k == 'sync')
    syncs = [t for k, _, t in log if k == 'sync']
    intervals = [b - a for a, b in zip(syncs, syncs[1:])]
    assert producer.skipped >= 5, producer.skipped
    # after the stall SYNC resumes on the period grid: never two SYNCs within 1 ms
    assert min(intervals) > 0.001, min(intervals)
    stats = producer.stats()
    assert stats.cycles == len(syncs) and 0.003 < stats.interval_median < 0.008
    assert stats.lead_max < 0.01


def test_a_failing_hook_is_reported_and_sync_continues() -> None:
    sent, errors = [], []
    producer = SyncProducer(lambda cob, data: sent.append(cob), 0.005, on_error=errors.append)

    def broken(cycle: int) -> None:
        raise RuntimeError('boom')

    producer.add_before_sync(broken)
    producer.start()
    time.sleep(0.1)
    producer.stop()
    assert len(sent) >= 10 and producer.hook_errors == len(sent)
    assert "failed: RuntimeError('boom')" in errors[0]
