"""``drive-bridge scan``: the demo's simulated drives (and an AKD) are found on their virtual
bus, named, matched to their drive family, and the starter config written boots them."""
from __future__ import annotations

import re
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import yaml

from bustools import config_from, demo_data, eventually, unique_channel
from configtools import REAL_EDS
from drive_bridge.cia402.statemachine import State
from drive_bridge.cli.main import main
from drive_bridge.config import ConfigError
from drive_bridge.config.loader import load_bus_config
from drive_bridge.families import IdentityMatch, families_for_identity, get_family
from drive_bridge.families.interface import eds_identity
from drive_bridge.joint import JointDriver, JointError
from drive_bridge.master.master import Master
from drive_bridge.model import BusConfig, Identity
from drive_bridge.sim import SimulatedBus, simulator_for
from drive_bridge.sim.testing import AKD_EDS, node_config
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint


@pytest.fixture
def demo_bus():
    """The demo's drives (nodes 2, 3 with two axes, 4) plus an AKD as node 5, powered on."""
    config = config_from(demo_data())
    with SimulatedBus(config):
        akd = simulator_for('akd')(node_config(5, eds=AKD_EDS, family='akd'))
        akd.connect(config.bus.channel)
        akd.power_on()
        time.sleep(0.2)  # boot-up frames out: the nodes answer SDO in pre-operational
        try:
            yield config
        finally:
            akd.close()


def test_scan_finds_the_drives_and_its_starter_config_boots_them(demo_bus, tmp_path, capsys) -> None:
    out = tmp_path / 'bus.yaml'
    channel = str(demo_bus.bus.channel)
    assert main(['scan', '--interface', 'virtual', '--channel', channel, '--nodes', '1-127', '-o', str(out)]) == 0
    printed = capsys.readouterr().out
    assert '4 node(s) answered of 127 asked' in printed
    akd_line = next(line for line in printed.splitlines() if line.startswith('node   5'))
    assert 'family akd' in akd_line and get_family('akd').vendor_name(0x6A) in akd_line
    config = load_bus_config(out)
    assert {n.node_id: n.family for n in config.nodes} == {2: 'generic_402', 3: 'generic_402', 4: 'generic_402',
                                                           5: 'akd'}
    assert [len(n.axes) for n in config.nodes] == [1, 2, 1, 1]
    assert config.nodes[3].identity.vendor_id == 0x6A
    master = Master(config)
    try:
        master.start()
        master.wait_until_operational(15.0)
        assert len(master.axes) == 5
        for axis in master.axes.values():
            assert axis.snapshot().state is not State.UNKNOWN
    finally:
        master.stop()


def test_families_recognise_their_shipped_identities() -> None:
    for family in ('akd', 'servostar', 'generic_402', 'opendrive'):
        eds = eds_identity(get_family(family).eds_for(1))
        identity = Identity(eds.device_type, eds.vendor_id, eds.product_code)
        best = families_for_identity(identity, eds.device_name)[0]
        assert best == (IdentityMatch.PRODUCT, family)
    # an unknown CiA 402 servo: the generic family by its device type; an I/O module: generic_301
    assert families_for_identity(Identity(0x00020192, 0x1234, 7))[0] == (IdentityMatch.DEVICE_TYPE, 'generic_402')
    assert families_for_identity(Identity(0x000F0191, 0x1234, 7)) == [(IdentityMatch.ANY, 'generic_301')]
    # a Kollmorgen product none of the families knows: both Kollmorgen families, by vendor
    assert [f for m, f in families_for_identity(Identity(0x00020192, 0x6A, 1)) if m is IdentityMatch.VENDOR] == \
        ['akd', 'servostar']
    assert families_for_identity(Identity(0xFFFF0192, 0x1234, 1))[0] == (IdentityMatch.DEVICE_TYPE, 'sinamics_s120')


def test_scan_errors_and_an_empty_bus(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit, match='2'):  # no silent 'virtual' default for a real bus
        main(['scan', '--channel', 'can0'])
    assert 'the following arguments are required: --interface' in capsys.readouterr().err
    assert main(['scan', '--interface', 'virtual', '--channel', 'x', '--nodes', '0-200']) == 2
    assert "'0-200' is outside the node ids 1..127" in capsys.readouterr().err
    assert main(['scan', '--interface', 'virtual', '--channel', 'x', '--nodes', 'two']) == 2
    assert "'two' is not a node id" in capsys.readouterr().err
    (tmp_path / 'taken.yaml').write_text('')
    assert main(['scan', '--interface', 'virtual', '--channel', 'x', '-o', str(tmp_path / 'taken.yaml')]) == 2
    assert 'exists already' in capsys.readouterr().err
    assert main(['scan', '--interface', 'nonesuch', '--channel', 'x']) == 2
    assert "interface='nonesuch'" in capsys.readouterr().err
    started = time.monotonic()
    assert main(['scan', '--interface', 'virtual', '--channel', unique_channel('empty'), '--timeout', '0.1']) == 1
    # one after the other: 127 x 0.1 s; at once: one timeout (its time: `python -m bench reactions`)
    assert time.monotonic() - started < 127 * 0.1 / 3, 'all 127 ids are asked at once, not one after the other'
    assert '0 node(s) answered of 127 asked' in capsys.readouterr().out


def test_a_full_transmit_queue_is_waited_out_then_a_clear_error(demo_bus) -> None:
    """SocketCAN answers a burst of 127 requests with ENOBUFS: a few failing sends are retried."""
    import can
    import canopen

    from drive_bridge.bag.errors import ScanError
    from drive_bridge.bag.scan import scan
    from drive_bridge.sim.faults import FaultyBus
    bus = FaultyBus(can.Bus(interface='virtual', channel=demo_bus.bus.channel))
    network = canopen.Network(bus)
    network.connect()
    try:
        bus.fail_sends(3)
        assert [n.node_id for n in scan(network, range(1, 8), 0.5)] == [2, 3, 4, 5]
        bus.fail_sends(1000)
        with pytest.raises(ScanError, match=r'SDO request 0x601 failed 5 times: .*transmit queue stays full'):
            scan(network, range(1, 8), 0.2)
    finally:
        network.disconnect()


EPOS4_EXAMPLE = Path(__file__).resolve().parents[1] / 'config' / 'maxon_epos4_example.yaml'
EPOS4_EDS = REAL_EDS / 'maxon_epos4_0x1018.eds'
FILLED = {'counts_per_revolution: TODO': 'counts_per_revolution: 4096', 'min_position: TODO': 'min_position: -3.0',
          'max_position: TODO': 'max_position: 3.0', 'max_velocity: TODO': 'max_velocity: 5.0'}


@pytest.fixture
def epos4_bus():
    """maxon's EPOS4 from its EDS alone (no value for 0x1000 and 0x1018 in the file), node 3."""
    data = yaml.safe_load(EPOS4_EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('epos4')
    with SimulatedBus(config_from(data)):
        time.sleep(0.2)
        yield data['bus']['channel']


@contextmanager
def enabled(joint: str, config: BusConfig) -> Iterator[tuple[JointDriver, TrajectoryExecutor]]:
    """A master on the simulated bus, the joint enabled, a trajectory executor on its cycle."""
    master = Master(config)
    try:
        master.start()
        master.wait_until_operational(15.0)
        axis = master.axes[joint]
        if 'error code 0x8130' in axis.fault_description():
            # the previous master of this test stopped, this one started: on a busy machine more
            # than the drive's heartbeat consumer time (300 ms) lay between their heartbeats
            axis.reset_fault(3.0)
        axis.enable(3.0)
        executor = TrajectoryExecutor(master.axes, cycle_period=config.master.cycle_period)
        master.add_cycle_listener(executor.check)
        yield axis, executor
    finally:
        master.stop()


def scan_to(channel: str, out: Path, *extra: str) -> int:
    return main(['scan', '--interface', 'virtual', '--channel', channel, '--nodes', '1-10', *extra, '-o', str(out)])


def test_scan_of_an_epos4_names_its_eds_and_the_starter_boots_but_moves_only_once_scaled(
        epos4_bus, tmp_path, capsys) -> None:
    out = tmp_path / 'bus.yaml'
    assert scan_to(epos4_bus, out, '--eds', str(REAL_EDS)) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith('node   3,'))
    # identity from the EDS's [DeviceInfo]; device type of a CiA 402 servo drive
    for part in ('device type 0x00020192', 'vendor 0x000000FB', 'product 0x61500000', 'rev 0x01700000',
                 'family generic_402'):
        assert part in line, line
    text = out.read_text()
    node = yaml.safe_load(text)['nodes']['node_3']
    assert (out.parent / node['dcf']).resolve() == EPOS4_EDS.resolve()
    assert (node['vendor_id'], node['product_code']) == ('0x000000FB', '0x61500000')
    assert node['axes'] == [{'joint': 'node_3_joint', 'slot': 0, 'scaling': {'counts_per_revolution': 'TODO'},
                             'limits': {'min_position': 'TODO', 'max_position': 'TODO', 'max_velocity': 'TODO'}}]

    config = load_bus_config(out)  # boots as written ...
    assert any('TODO' in w for w in config.warnings)
    with enabled('node_3_joint', config) as (axis, executor):
        here = axis.snapshot().position
        keys = ('nodes.node_3.axes[0].scaling.counts_per_revolution, nodes.node_3.axes[0].limits.min_position, '
                'nodes.node_3.axes[0].limits.max_position, nodes.node_3.axes[0].limits.max_velocity are TODO')
        # ... but takes no trajectory and no command, naming the keys to set
        with pytest.raises(TrajectoryError, match=re.escape(keys)):
            executor.submit(Trajectory((axis.joint,), (TrajectoryPoint(0.3, (here + 100,)),)))
        with pytest.raises(JointError, match=re.escape(keys)):
            axis.check_command(position=here + 100)

    for todo, value in FILLED.items():
        text = text.replace(todo, value)
    filled = tmp_path / 'filled.yaml'
    filled.write_text(text)
    config = load_bus_config(filled)
    assert not any('TODO' in w for w in config.warnings)
    with enabled('node_3_joint', config) as (axis, executor):
        here = axis.snapshot().position
        handle = executor.submit(Trajectory((axis.joint,), (TrajectoryPoint(0.3, (here + 0.2,)),)))
        assert handle is not None and handle.wait(5.0), handle and handle.reason
        eventually(lambda: abs(axis.snapshot().position - here - 0.2) < 3e-3, 3.0, 'the goal in rad')


def test_a_starter_without_a_matching_eds_says_to_give_one_and_scaling_none_is_device_units(
        epos4_bus, tmp_path, capsys) -> None:
    out = tmp_path / 'bus.yaml'
    assert scan_to(epos4_bus, out) == 0
    text = out.read_text()
    assert yaml.safe_load(text)['nodes']['node_3']['dcf'] == 'TODO'
    assert "# dcf: TODO: the vendor's EDS for vendor 0x000000FB, product 0x61500000" in text
    with pytest.raises(ConfigError, match=r"nodes\.node_3\.dcf: TODO: give this drive's EDS or DCF .*scan --eds DIR"):
        load_bus_config(out)
    # the integrator's choices: the EDS, device units on purpose, no limits
    text = text.replace('dcf: TODO', f'dcf: {EPOS4_EDS}').replace("scaling:\n        counts_per_revolution: TODO",
                                                                   'scaling: none')
    for key in ('min_position', 'max_position', 'max_velocity'):
        text = text.replace(f'{key}: TODO', f'{key}: {-1e9 if key == "min_position" else 1e9}')
    out.write_text(text)
    config = load_bus_config(out)
    assert not any('TODO' in w or 'unscaled' in w for w in config.warnings), config.warnings
    (axis,) = config.axes
    assert axis[1].scaling.position_factor == 1.0 and axis[1].limits.todo == ()
