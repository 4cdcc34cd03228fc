"""SimulatedBus for a BusConfig, the simulator registry, options, clean shutdown, and
the per-SYNC cost of one simulated drive."""
from __future__ import annotations

import struct
import threading
import time

import canopen
import pytest

from drive_bridge.cia402.statemachine import State
from drive_bridge.model import BusConfig, BusInterface, SimulationConfig
from drive_bridge.sim import SimDrive402, SimulatedBus, SimulatedSlave, simulated_families, simulator_for
from drive_bridge.sim.bench import measure
from drive_bridge.sim.options import AXIS_OPTIONS, SLAVE_OPTIONS, describe
from drive_bridge.sim.slave import NOTIFIER_CYCLE
from drive_bridge.sim.testing import (
    GENERIC402_2AXIS_EDS,
    GENERIC402_EDS,
    FrameLog,
    SyncLoop,
    node_config,
    unique_channel,
    wait_until,
)


def three_node_config(channel: str, options: dict | None = None) -> BusConfig:
    nodes = (node_config(1, 'left'), node_config(2, 'arm', eds=GENERIC402_2AXIS_EDS),
             node_config(3, 'io', eds=GENERIC402_EDS, family='generic_301'))
    return BusConfig(bus=BusInterface(channel=channel), nodes=nodes,
                     simulation=SimulationConfig(enabled=True, options=options or {}))


def test_registry_maps_families_to_simulators() -> None:
    assert issubclass(simulator_for('generic_402'), SimDrive402)  # the EDS-faithful subclass
    assert simulator_for('generic_301') is SimulatedSlave
    assert {'generic_301', 'generic_402'} <= set(simulated_families())
    with pytest.raises(KeyError, match='generic_402'):
        simulator_for('no_such_family')


def test_three_drives_on_one_bus_and_a_clean_stop() -> None:
    channel = unique_channel()
    threads_before = set(threading.enumerate())
    master = canopen.Network()
    master.NOTIFIER_CYCLE = NOTIFIER_CYCLE
    master.connect(interface='virtual', channel=channel)
    log = FrameLog(master)
    config = three_node_config(channel, {'left': {'serial_number': 11}, 'arm': {'serial_number': 22,
                                                                                'initial_position': [0, 77]}})
    try:
        with SimulatedBus(config) as bus:
            for node_id in (1, 2, 3):
                assert log.wait_for(0x700 + node_id)[0].data == b'\x00'
            assert bus.drive('arm') is bus.drive(2) and isinstance(bus.drive(2), SimDrive402)
            assert type(bus.drive('io')) is SimulatedSlave
            assert len(bus.drive(2).axes) == 2 and bus.drive(2).axis(1).position == 77
            remotes = {i: master.add_node(i, canopen.import_od(str(GENERIC402_EDS), i)) for i in (1, 2, 3)}
            assert [remotes[i].sdo[0x1018][4].raw for i in (1, 2, 3)] == [11, 22, 0]
            master.send_message(0x000, b'\x01\x00')  # start all
            wait_until(lambda: all(d.nmt_state == 'OPERATIONAL' for d in bus.drives.values()), 0.5)
            t = time.monotonic()
            SyncLoop(master, 0.005).run(3)
            for node_id in (1, 2, 3):
                assert len(log.wait_for(0x180 + node_id, 3, since=t)) == 3
            assert len(log.wait_for(0x382, 3, since=t)) == 3, 'second axis of the 2-axis node'
            remotes[1].sdo[0x6040].raw = 0x06
            assert bus.drive(1).axis().state is State.READY_TO_SWITCH_ON
            assert bus.drive(2).axis().state is State.SWITCH_ON_DISABLED
            t = time.monotonic()
            master.send_message(0x000, b'\x81\x02')  # reset node 2 only
            log.wait_for(0x702, since=t)
            time.sleep(0.05)
            assert not log.frames(0x701, since=t) and not log.frames(0x703, since=t)
            assert bus.drive(1).nmt_state == 'OPERATIONAL'
            with pytest.raises(KeyError, match='left'):
                bus.drive('nobody')
        assert not bus.running
    finally:
        master.disconnect()
    wait_until(lambda: set(threading.enumerate()) <= threads_before, 2.0, 'no leaked threads')


def test_stop_is_idempotent_and_start_again_works() -> None:
    bus = SimulatedBus(three_node_config(unique_channel()))
    bus.stop()
    bus.start()
    assert all(d.powered for d in bus.drives.values())
    bus.stop()
    bus.stop()
    assert not any(d.powered for d in bus.drives.values())


@pytest.mark.parametrize('options, message', [
    ({'left': {'bootdelay': 1}}, "unknown simulation option 'bootdelay' for node 'left'"),
    ({'left': {'boot_delay': 'soon'}}, "'boot_delay' of node 'left': expected a number"),
    ({'left': {'boot_delay': -1}}, 'below the minimum'),
    ({'arm': {'inertia': [1e-4]}}, "'inertia' of node 'arm': 1 values for 2 axes"),
    ({'io': {'inertia': 1e-4}}, "unknown simulation option 'inertia' for node 'io'"),  # a 301 node has no axes
    ({'nobody': {}}, "unknown node 'nobody'"),
    ({'left': {'serial_number': 1.5}}, 'expected an integer'),
])
def test_option_errors_name_node_and_option(options: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace('(', r'\(')):
        SimulatedBus(three_node_config(unique_channel(), options))


def test_non_virtual_interface_is_refused() -> None:
    config = BusConfig(bus=BusInterface(interface='socketcan', channel='can0'), nodes=())
    with pytest.raises(ValueError, match='virtual'):
        SimulatedBus(config)


def test_options_are_documented() -> None:
    text = describe({**SLAVE_OPTIONS, **AXIS_OPTIONS})
    for name in ('boot_delay', 'serial_number', 'sdo_delay', 'lag_time_constant', 'inertia', 'friction',
                 'home_switch_position', 'homing_timeout', 'initial_position'):
        assert name in text


def test_sdo_delay_and_boot_delay_options() -> None:
    channel = unique_channel()
    config = BusConfig(bus=BusInterface(channel=channel), nodes=(node_config(4, 'slow'),),
                       simulation=SimulationConfig(options={'slow': {'boot_delay': 0.1, 'sdo_delay': 0.05}}))
    master = canopen.Network()
    master.NOTIFIER_CYCLE = NOTIFIER_CYCLE
    master.connect(interface='virtual', channel=channel)
    log = FrameLog(master)
    try:
        with SimulatedBus(config):
            t = time.monotonic()
            boot = log.wait_for(0x704, timeout=1.0)[0]
            assert boot.timestamp - t >= 0.08
            node = master.add_node(4, canopen.import_od(str(GENERIC402_EDS), 4))
            t = time.monotonic()
            assert node.sdo[0x1000].raw == 0x00020192
            assert time.monotonic() - t >= 0.045
    finally:
        master.disconnect()


def test_per_sync_cost_of_one_simulated_drive() -> None:
    result = measure(cycles=300, period=0.004)
    print(f"\nper-SYNC cost, 1-axis drive (2 RPDOs in, 2 TPDOs out): paced mean {result['paced_mean'] * 1e6:.0f} us,"
          f" tight-loop median {result['tight_median'] * 1e6:.0f} us, p99 {result['tight_p99'] * 1e6:.0f} us")
    assert result['paced_count'] >= 290
    assert result['tight_median'] < 0.001  # generous: about 60 us measured on the 2-core VM


def test_standalone_slave_connect_close_and_rpdo_length_error() -> None:
    channel = unique_channel()
    master = canopen.Network()
    master.NOTIFIER_CYCLE = NOTIFIER_CYCLE
    master.connect(interface='virtual', channel=channel)
    log = FrameLog(master)
    try:
        with SimDrive402(node_config(9)).connect(channel) as sim:
            sim.power_on()
            log.wait_for(0x709)
            master.send_message(0x000, b'\x01\x09')
            wait_until(lambda: sim.nmt_state == 'OPERATIONAL', 0.5)
            t = time.monotonic()
            master.send_message(0x209, b'\x06\x00')  # RPDO1 maps 5 bytes: too short
            emcy = log.wait_for(0x89, since=t)[0]
            assert struct.unpack_from('<HB', emcy.data) == (0x8210, 0x11)
            assert sim.error_register == 0, 'a length error is an event, not a lasting error'
            assert sim.error_history == [0x8210]
        assert not sim.powered
    finally:
        master.disconnect()
