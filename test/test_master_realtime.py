"""master.realtime_priority: the cycle thread runs SCHED_FIFO with a 0.5 ms GIL switch interval
while it runs (or the master says once why not and runs on); bad values are refused naming the key."""
from __future__ import annotations

import os
import sys
import threading

import pytest

from bustools import config_from, demo_data, eventually, running
from drive_bridge.config import ConfigError
from drive_bridge.master.events import EventKind, Level
from drive_bridge.master.realtime import make_realtime, thread_policy


def _policy_of(prefix: str) -> list[int]:
    return [thread_policy(t.native_id) for t in threading.enumerate()
            if t.name.startswith(prefix) and t.native_id is not None]


def _permitted() -> bool:
    result: list[str | None] = []
    probe = threading.Thread(target=lambda: result.append(make_realtime(1)))
    probe.start()
    probe.join()
    return result[0] is None


@pytest.mark.parametrize(('value', 'expected'), [
    (0, r'master\.realtime_priority: expected an integer 1\.\.99, got 0'),
    (100, r'master\.realtime_priority: expected an integer 1\.\.99, got 100'),
    ('high', r"master\.realtime_priority: expected an integer 1\.\.99, got 'high'"),
])
def test_a_priority_outside_1_to_99_is_refused_naming_the_key(value: object, expected: str) -> None:
    data = demo_data()
    data['master']['realtime_priority'] = value
    with pytest.raises(ConfigError, match=expected):
        config_from(data)


def test_absent_or_null_is_normal_scheduling() -> None:
    data = demo_data()
    assert config_from(data).master.realtime_priority is None
    data['master']['realtime_priority'] = None
    assert config_from(data).master.realtime_priority is None


def test_the_cycle_thread_runs_sched_fifo_or_the_master_says_why_not() -> None:
    data = demo_data()
    data['master']['realtime_priority'] = 10
    permitted = _permitted()
    before = sys.getswitchinterval()
    with running(config_from(data)) as (master, _sim):
        assert master.sync is not None
        eventually(lambda: master.sync.stats().cycles > 20, 3.0, '20 cycles')  # type: ignore[union-attr]
        configured = [e for e in master.events if e.kind is EventKind.CONFIGURED and 'SCHED_FIFO' in e.message]
        assert sys.getswitchinterval() == pytest.approx(min(before, 0.0005))
        if permitted:
            assert _policy_of('drive_bridge-sync') == [os.SCHED_FIFO]
            assert [e.level for e in configured] == [Level.INFO], configured
            assert 'priority 10' in configured[0].message
        else:
            assert [e.level for e in configured] == [Level.WARN], configured
            assert 'master.realtime_priority 10: SCHED_FIFO refused for the cycle thread' in configured[0].message
        # the CAN receive, SDO worker and supervisor threads keep normal priority
        assert set(_policy_of('drive_bridge-supervisor')) == {os.SCHED_OTHER}
        assert {thread_policy(t.native_id) for t in threading.enumerate()
                if 'Notifier' in t.name and t.native_id} == {os.SCHED_OTHER}
    assert sys.getswitchinterval() == pytest.approx(before)  # the process's setting is given back


def test_without_the_key_every_thread_keeps_normal_priority() -> None:
    with running(config_from(demo_data())) as (master, _sim):
        eventually(lambda: master.sync.stats().cycles > 5, 3.0, '5 cycles')  # type: ignore[union-attr]
        assert set(_policy_of('drive_bridge-sync')) == {os.SCHED_OTHER}


def test_a_priority_the_kernel_refuses_gives_the_reason() -> None:
    result: list[str | None] = []
    probe = threading.Thread(target=lambda: result.append(make_realtime(1000)))  # beyond SCHED_FIFO's range
    probe.start()
    probe.join()
    assert result[0] and 'Invalid argument' in result[0]


def test_two_real_time_masters_give_the_switch_interval_back_only_when_both_stopped() -> None:
    before = sys.getswitchinterval()
    configs = []
    for _ in range(2):
        data = demo_data()
        data['master']['realtime_priority'] = 10
        configs.append(config_from(data))
    first = running(configs[0])
    master, _sim = first.__enter__()
    try:
        eventually(lambda: master.sync.stats().cycles > 5, 3.0, '5 cycles')  # type: ignore[union-attr]
        with running(configs[1]) as (second, _sim2):
            eventually(lambda: second.sync.stats().cycles > 5, 3.0, '5 cycles')  # type: ignore[union-attr]
            first.__exit__(None, None, None)  # the first stops while the second still runs
            first = None
            assert sys.getswitchinterval() == pytest.approx(min(before, 0.0005))
    finally:
        if first is not None:
            first.__exit__(None, None, None)
    assert sys.getswitchinterval() == pytest.approx(before)
