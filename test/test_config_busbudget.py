"""The bus budget of the configuration check: warned over 70 %, refused over 100 % unless
allowed, unknown without a bit rate; and the count matches what the bus really carries."""
from __future__ import annotations

import re
import threading
import time

import can
import pytest

from bustools import config_from, demo_data, running
from drive_bridge.cia301.busbits import frame_bits
from drive_bridge.config import ConfigError
from drive_bridge.config.busbudget import budget_of
from timingtools import CycleWatch


def demo_at(sync_us: int, **bus: object) -> dict:
    data = demo_data()
    data['master']['sync_period'] = sync_us
    data['bus'].update(bus)
    return data


def test_frame_bits_with_worst_case_stuffing() -> None:
    assert frame_bits(8, stuffed=True) == 135 and frame_bits(0, stuffed=True) == 55
    assert frame_bits(6, stuffed=True) == 115 and frame_bits(8) == 111
    assert frame_bits(8, remote=True) == 47 and frame_bits(8, extended=True) == 131


def test_the_demo_fits_at_4_ms_and_the_check_stays_quiet() -> None:
    config = config_from(demo_at(4000))
    assert not [w for w in config.warnings if 'bus load' in w]
    load = budget_of(config).load
    assert load is not None and 0.3 < load < 0.7


def test_over_70_percent_warns_with_the_figure_and_the_period_that_fits() -> None:
    config = config_from(demo_at(2500))
    (warning,) = [w for w in config.warnings if 'bus load' in w]
    assert re.search(r'bus load 7\d% of 1000 kbit/s', warning), warning
    shortest = int(re.search(r'master.sync_period to at least (\d+) µs', warning).group(1))  # type: ignore[union-attr]
    assert 2500 < shortest < 3000
    assert not [w for w in config_from(demo_at(shortest + 1)).warnings if 'bus load' in w]
    assert 'smaller PDOs' in warning


def test_over_100_percent_is_refused_unless_the_config_allows_overload() -> None:
    with pytest.raises(ConfigError) as caught:
        config_from(demo_at(1500))
    text = str(caught.value)
    assert re.search(r'bus: bus load 13\d% of 1000 kbit/s', text) and 'cannot carry it' in text, text
    assert 'allow_overload: true' in text
    config = config_from(demo_at(1500, allow_overload=True))
    assert config.allow_overload
    assert [w for w in config.warnings if 'bus load 13' in w]  # still said, not refused


def test_half_the_bit_rate_doubles_the_load() -> None:
    full, half = (budget_of(config_from(demo_at(10000, bitrate=rate))).load for rate in (1_000_000, 500_000))
    assert full is not None and half == pytest.approx(2 * full)


def test_without_a_bit_rate_the_budget_is_unknown_not_refused() -> None:
    config = config_from(demo_at(1000, bitrate=None))  # would be far over at 1 Mbit/s
    (warning,) = [w for w in config.warnings if 'bus load' in w]
    assert 'bus load unknown' in warning and 'bitrate is null' in warning


def test_the_counted_frames_are_what_the_bus_carries() -> None:
    config = config_from(demo_at(4000))
    expected = budget_of(config).frames_per_second
    with running(config) as (master, _sim):
        for axis in master.axes.values():
            axis.enable()
        counted = []
        lock = threading.Lock()

        def count(msg: can.Message) -> None:
            with lock:
                counted.append(msg.arbitration_id)
        watch = CycleWatch(master)
        master.add_frame_listener(count)
        time.sleep(1.0)
        with lock:
            frames = len(counted)
        cycles = watch.cycles
    # worst case counted: every RPDO every cycle and every synchronous TPDO; per cycle the bridge
    # ran (a busy machine skips grid points: fewer cycles, as many frames each)
    per_cycle = expected * config.master.sync_period
    assert cycles > 0 and 0.6 * per_cycle * cycles < frames <= 1.1 * per_cycle * (cycles + 1), \
        (frames, cycles, per_cycle)


def test_an_axis_whose_mode_is_picked_at_boot_counts_its_ip_rpdo() -> None:
    from test_any402 import SCALE

    from configtools import REAL_EDS
    config = config_from({'bus': {'interface': 'virtual', 'channel': 'budget_ip', 'bitrate': 1_000_000},
                          'master': {'sync_period': 4000},
                          'nodes': {'j': {'dcf': str(REAL_EDS / 'PRL120.eds'), 'node_id': 2, **SCALE}}})
    axis = config.nodes[0].axes[0]
    assert axis.auto_mode is not None and axis.auto_mode.candidates == (7,)  # ip picked at boot
    assert '(1 SYNC, 2 RPDO, 2 TPDO' in budget_of(config).describe()  # 6040, and 60C1:1 for ip
