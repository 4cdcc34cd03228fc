"""Boot steps the EDS decides: checked at load time with the key to change, a refusal that
repeats identically reported once as permanent (not retried for ever), and Elmo.dcf, whose
limit on 0x1016:01 contradicts CiA 301: named, and the drive keeps its heartbeat consumer."""
from __future__ import annotations

import logging
import time

import pytest

from configtools import REAL_EDS
from drive_bridge.config import ConfigError, parse_bus_config
from drive_bridge.master.events import EventKind
from drive_bridge.master.master import Master
from drive_bridge.sim import SimulatedBus

SCALE = {'scale_pos_from_dev': 0.0015}


def bus(name: str, channel: str, **node: object) -> dict:
    return {'bus': {'channel': channel}, 'master': {'sync_period': 4000, 'heartbeat_producer': 100},
            'nodes': {'d': {'dcf': str(REAL_EDS / name), 'node_id': 4, **SCALE, **node}},
            'simulation': {'enabled': True}}


def problems(data: dict) -> list[str]:
    with pytest.raises(ConfigError) as caught:
        parse_bus_config(data, 'drives.yaml', REAL_EDS)
    return str(caught.value).splitlines()


def test_elmo_dcf_inconsistency_named_and_heartbeat_consumer_kept() -> None:
    config = parse_bus_config(bus('Elmo.dcf', 'any402_elmo'), 'drives.yaml', REAL_EDS)
    assert config.warnings == (
        "drives.yaml: nodes.d: Elmo.dcf [1016sub1]: HighLimit 0xFFFF contradicts CiA 301's layout of 0x1016:01 "
        '(producer node id in bits 16-23, time in bits 0-15): no entry naming a producer would fit; following '
        'CiA 301 (writing 0x007F012C)',)
    assert config.nodes[0].heartbeat_consumer
    sim = SimulatedBus(config).start()
    master = Master(config)
    try:
        master.start()
        master.wait_until_operational(5.0)
        # the drive watches the master: node 127, 300 ms (100 ms x the multiplier 3)
        assert master.sdo_read(4, 0x1016, 1)[1] == 127 << 16 | 300
        assert [e.kind for e in master.events if e.kind is EventKind.BOOT_FAILED] == []
    finally:
        master.stop()
        sim.stop()


def test_heartbeat_settings_the_eds_cannot_take_name_the_key() -> None:
    assert problems(bus('PRL120.eds', 'x', heartbeat_producer=40000)) == [
        'drives.yaml: nodes.d.heartbeat_producer: 40000 ms is above the HighLimit 32767 of 0x1017 in PRL120.eds']
    assert problems(bus('605.3150.51-V-EK-3-60.eds', 'x', heartbeat_producer=100)) == [
        'drives.yaml: nodes.d.heartbeat_producer: 605.3150.51-V-EK-3-60.eds has no 0x1017 (producer heartbeat '
        'time): the node sends no heartbeat; set heartbeat_producer: 0 and guard_time_ms (e.g. 100)']


@pytest.mark.parametrize('listened', [True, False], ids=['with an event listener', 'plain python logging'])
def test_a_refusal_that_repeats_is_permanent_and_reported_once(caplog: pytest.LogCaptureFixture,
                                                               listened: bool) -> None:
    # technosoft.eds has no csp in 0x6502: the drive refuses 0x6060 = 8 with 0x06090030 every time
    data = bus('technosoft.eds', f'any402_refusal_{listened}', sdo=[{'index': 0x6060, 'sub_index': 0, 'value': 8}],
               boot_retry_interval_ms=100)
    config = parse_bus_config(data, 'drives.yaml', REAL_EDS)
    sim = SimulatedBus(config).start()
    master = Master(config)
    heard: list[str] = []
    if listened:
        master.add_event_listener(lambda event: heard.append(event.message))
    caplog.set_level(logging.INFO, logger='drive_bridge.master')
    try:
        master.start()
        node = master.nodes['d']
        deadline = time.monotonic() + 5.0
        while not any('permanent' in e.message for e in master.events) and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.5)  # five retry intervals: nothing more happens
        failed = [e.message for e in master.events if e.kind is EventKind.BOOT_FAILED]
        assert failed == [
            'node 4 (d) boot step "boot SDO": node 4 object 0x6060:00: SDO abort 0x06090030: value range of '
            'parameter exceeded (drives.yaml: nodes.d.sdo[0]) (the same refusal on 2 attempts: permanent, not '
            'retried; change the configuration)']
        assert node.boot_attempts == 2
        printed = [r.getMessage() for r in caplog.records if 'permanent' in r.getMessage()]
        assert printed == ([] if listened else failed)
        assert [m for m in heard if 'permanent' in m] == (failed if listened else [])
    finally:
        master.stop()
        sim.stop()


def test_the_start_up_line_says_what_is_mapped_polled_and_why() -> None:
    # the older FAULHABER: fixed maps with only the controlword and the statusword
    config = parse_bus_config(bus('605.3150.51-V-EK-3-60.eds', 'x'), 'drives.yaml', REAL_EDS)
    (node,) = config.nodes
    assert node.pdo_summary == (
        'PDO map (fitted to the EDS; the standard map does not fit: RPDO1 has a fixed mapping): RPDO1 6040; '
        'TPDO1 6041; by SDO: 607A (not PDO-mappable), 60FF (not PDO-mappable), 6060 (not PDO-mappable); '
        'polled: 6064 (not PDO-mappable), 6061 (not PDO-mappable); estimated from position: 606C (not PDO-mappable)')
    assert node.polled == ((0x6064, 0), (0x6061, 0)) and node.axes[0].estimated_velocity
    assert node.guard_time_ms == 100 and node.heartbeat_producer_ms == 0  # no 0x1017: guarded


def test_a_map_that_streams_nothing_picks_no_mode_and_an_underived_map_picks_the_best() -> None:
    from drive_bridge.cia402.bootmodes import pick
    from drive_bridge.model import ModeChoice
    every = 0x3FF  # 0x6502: pp, vl, pv, hm, ip, csp, csv, cst supported
    refused = pick(8, ModeChoice(candidates=()), every, False)
    assert refused.mode == 0 and 'its PDO map streams no mode' in refused.problem
    assert pick(8, ModeChoice(), every, False).mode == 8  # explicit PDOs: the best streaming mode
