"""master.sync_window (0x1007) in the configuration, and the node's sync_period parameter
checked like the file's period: the window must fit, the bus budget must hold."""
from __future__ import annotations

import re

import pytest
import yaml
from rclpy.parameter import Parameter

from bustools import config_from, demo_data
from drive_bridge.config import ConfigError
from drive_bridge.ros.bridge import load_config
from drive_bridge.ros.errors import StartupError
from drive_bridge.ros.node import BusNode
from drive_bridge.ros.parameters import BridgeParameters
from rostools import RosHarness


def demo(sync_us: int = 4000, **master: object) -> dict:
    data = demo_data()
    data['master']['sync_period'] = sync_us
    data['master'].update(master)
    return data


def test_the_window_is_read_in_seconds_and_absent_or_zero_means_not_written() -> None:
    assert config_from(demo(sync_window=1500)).master.sync_window == pytest.approx(0.0015)
    assert config_from(demo()).master.sync_window is None
    zero = config_from(demo(sync_window=0))  # lely's default: window not used
    assert zero.master.sync_window is None and not [w for w in zero.warnings if 'sync_window' in w]


@pytest.mark.parametrize('sync_us, window, expected', [
    (4000, 4000, r'master\.sync_window: 4000 µs must be > 0 and shorter than the SYNC period '
                 r'\(master\.sync_period = 4000 µs\)'),
    (4000, 9000, r'master\.sync_window: 9000 µs must be > 0 and shorter than the SYNC period'),
    (0, 1000, r'master\.sync_window: 1000 µs needs a SYNC period \(master\.sync_period is 0: no SYNC\)'),
    (4000, -5, r'master\.sync_window: .*>= 0'),
    (4000, 'soon', r'master\.sync_window: .*integer'),
])
def test_a_window_that_does_not_fit_the_period_is_refused_naming_the_key(sync_us: int, window: object,
                                                                          expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        config_from(demo(sync_us, sync_window=window))


def params(data: dict, sync_period: float) -> BridgeParameters:
    return BridgeParameters(config_yaml=yaml.safe_dump(data, sort_keys=False), sync_period=sync_period)


def test_the_sync_period_parameter_gets_the_budget_warning_of_its_own_period() -> None:
    config = load_config(params(demo(4000), 0.0025))
    assert config.master.sync_period == 0.0025
    (warning,) = [w for w in config.warnings if 'bus load' in w]
    assert warning.startswith('parameter sync_period: 2500 µs: bus load 7')
    assert re.search(r'set sync_period to at least \d+ µs', warning), warning
    # the file's own (2.5 ms) warning does not survive an override that fits
    quiet = load_config(params(demo(2500), 0.004))
    assert quiet.master.sync_period == 0.004 and not [w for w in quiet.warnings if 'bus load' in w]


def test_the_sync_period_parameter_must_leave_room_for_the_window() -> None:
    with pytest.raises(ConfigError, match=r'parameter sync_period: master\.sync_window: 3000 µs must be > 0 and '
                                          r'shorter than the SYNC period \(sync_period = 2000 µs\)'):
        load_config(params(demo(4000, sync_window=3000), 0.002))


def test_an_overloading_sync_period_parameter_stops_the_node_with_load_and_shortest_period(ros: RosHarness) -> None:
    with pytest.raises(StartupError) as caught:
        BusNode(context=ros.context, parameter_overrides=[
            Parameter('config_yaml', value=yaml.safe_dump(demo(4000), sort_keys=False)),
            Parameter('sync_period', value=0.0015)])
    text = str(caught.value)
    assert 'parameter sync_period: 1500 µs: bus load 13' in text, text
    fits = int(re.search(r'it fits from (\d+) µs', text).group(1))  # type: ignore[union-attr]
    assert 1500 < fits < 2500
    assert 'allow_overload' in text
    data = demo(4000)
    data['bus']['allow_overload'] = True
    config = load_config(params(data, 0.0015))
    assert config.master.sync_period == 0.0015 and [w for w in config.warnings if 'bus load 13' in w]
