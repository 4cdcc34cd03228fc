"""The ``akd`` drive family: a node with ``family: akd`` and no dcf loads with the shipped EDS
and the family's PDO map, the map keeps the AKD's PDO rules and works on the simulated AKD
when written the CiA 301 way, the EMCY table decodes, and the bridge boots the example config."""
from __future__ import annotations

import copy
import struct
import time
from pathlib import Path

import canopen
import pytest
import yaml
from canopen.objectdictionary import ODVariable

from akdtools import akd_bus
from bustools import REPO, eventually, running, unique_channel
from configtools import load_yaml
from drive_bridge.cia301.cob import predefined_cob_id
from drive_bridge.cia301.emcy import decode_emcy, describe_code
from drive_bridge.cia402.statemachine import State
from drive_bridge.config import load_bus_config, parse_bus_config
from drive_bridge.families import get_family
from drive_bridge.model import AxisConfig, PdoConfig
from drive_bridge.resources import family_data

AKD_EDS = family_data('akd', 'akd.eds')
EXAMPLE = REPO / 'config' / 'akd_pvt_example.yaml'
NODE = 3

MINIMAL = """\
bus: {interface: virtual, channel: akd_family_test}
master: {sync_period: %d}
nodes:
  axis_a:
    node_id: 3
    family: akd
    axes:
      - joint: a
        mode: ip
        scaling: {counts_per_revolution: 1048576}
"""


def check_akd_pdo_rules(od: canopen.ObjectDictionary, kind: str, pdo: PdoConfig, node_id: int) -> None:
    """The AKD's PDO rules (manual §5.4.6, §6.3; akd.md §2.4, §10.12)."""
    assert 1 <= pdo.number <= 4, 'four PDOs each way'
    assert pdo.cob_id == predefined_cob_id(kind, pdo.number, node_id)
    assert 1 <= len(pdo.mapping) <= 8 and pdo.bits <= 64, 'at most 8 entries and 8 bytes'
    allowed = set(range(1, 241)) | {255} if kind == 'rpdo' else set(range(0, 241)) | {255}
    assert pdo.transmission in allowed
    for entry in pdo.mapping:
        assert entry.bits % 8 == 0, 'mapping is byte-granular'
        var = od[entry.index] if entry.subindex == 0 and isinstance(od[entry.index], ODVariable) \
            else od[entry.index][entry.subindex]
        assert var.pdo_mappable, f'0x{entry.index:04X}:{entry.subindex} is not mappable'
        assert len(var) == entry.bits
        assert var.writable if kind == 'rpdo' else var.readable


@pytest.mark.parametrize('sync_period, transmission', [(4000, 1), (0, 255)])
def test_node_with_family_akd_loads_with_the_shipped_eds_and_map(tmp_path: Path, sync_period: int,
                                                                   transmission: int) -> None:
    config = load_yaml(tmp_path, MINIMAL % sync_period)
    node = config.node('axis_a')
    assert node.family == 'akd' and node.eds_path == AKD_EDS
    assert node.od[0x1000].default == 0x00020192 and node.od[0x1018][1].default == 0x6A
    assert node.od[0x1014].default == 0x80 + NODE, '$NODEID resolved'
    assert node.axes[0].ip_submode == -2, 'PVT is the family default'
    family = get_family('akd')
    assert (node.rpdo, node.tpdo) == family.default_pdos(NODE, node.axes, synchronous=sync_period > 0)
    for kind, pdos in (('rpdo', node.rpdo), ('tpdo', node.tpdo)):
        for pdo in pdos:
            check_akd_pdo_rules(node.od, kind, pdo, NODE)
            assert pdo.transmission == transmission
    rx = {p.number: [(e.index, e.subindex) for e in p.mapping] for p in node.rpdo}
    tx = {p.number: [(e.index, e.subindex) for e in p.mapping] for p in node.tpdo}
    assert rx[2] == [(0x60C1, 1), (0x60C1, 2)] and rx[3] == [(0x60C1, 3)], "the manual's PVT mapping"
    assert (0x6040, 0) in rx[1] and (0x6060, 0) in rx[1]
    assert {(0x607A, 0), (0x60FF, 0)} <= set(rx[4])
    assert {(0x6041, 0), (0x6061, 0), (0x60C4, 2)} <= set(tx[1]), 'free PVT places come with the statusword'
    assert {(0x6064, 0), (0x606C, 0)} <= set(tx[2])


def test_interpolation_linear_and_the_example_config() -> None:
    config = load_bus_config(EXAMPLE)
    assert config.simulation.enabled and config.warnings == ()
    axis = config.nodes[0].axes[0]
    assert config.nodes[0].family == 'akd' and config.nodes[0].eds_path == AKD_EDS
    assert axis.mode == 7 and axis.ip_submode == -2
    assert axis.scaling.position_factor == pytest.approx(2 * 3.141592653589793 / 2 ** 20)
    with pytest.raises(ValueError):
        get_family('akd').default_pdos(1, [AxisConfig('a'), AxisConfig('b', slot=1)], True)


def test_emcy_texts_decode() -> None:
    family = get_family('akd')
    texts = family.emcy_texts
    assert len(texts) == 171, 'every row of the manual\'s table'
    assert describe_code(0x8585, texts) == 'n705 Warning: PVT buffer underflow'
    assert describe_code(0x8584, texts) == 'n704 Warning: PVT buffer overflow'
    assert texts[0x8130] == 'F129 Life Guard Error or Heartbeat Error'
    assert texts[0xFF01] == 'F702 Fieldbus communication lost'
    assert texts[0x0000] == 'Emergency error free'
    assert family.modes.interpolation_fault_codes == {0x8584, 0x8585}
    # a frame from the simulated drive, decoded as the bridge does
    with akd_bus(NODE) as (_bench, sniffer, m, sims):
        mark = sniffer.mark
        sims[0].inject_fault(0x4310)
        frame = sniffer.wait(0x80 + NODE, mark)[0]
        event = decode_emcy(NODE, 'akd', frame.data, frame.stamp, texts)
        assert event.code == 0x4310 and event.text == 'F235 Excess temperature, drive (heat sink)'
        assert frame.data[3] == 0x01, 'AKD category byte'


def write_pdo_the_cia_way(remote: canopen.RemoteNode, kind: str, config: PdoConfig) -> None:
    """As the bridge's boot does (master/boot.py): canopen's PdoMap.save = COB-ID invalid, type,
    sub0 = 0, entries, sub0 = n, COB-ID valid."""
    pdo_map = (remote.rpdo if kind == 'rpdo' else remote.tpdo)[config.number]
    pdo_map.clear()
    pdo_map.cob_id = config.cob_id
    pdo_map.trans_type = config.transmission
    if kind == 'tpdo':
        pdo_map.event_timer = config.event_timer
    for entry in config.mapping:
        pdo_map.add_variable(entry.index, entry.subindex, entry.bits)
    pdo_map.enabled = True
    pdo_map.save()


def test_default_map_written_by_sdo_works_on_the_simulated_akd() -> None:
    family = get_family('akd')
    rpdos, tpdos = family.default_pdos(NODE, [AxisConfig('a', mode=7)], synchronous=True)
    with akd_bus(NODE, options={'lag_time_constant': 0.0}) as (bench, sniffer, m, _sims):
        remote = bench.master[NODE]  # canopen's RemoteNode with the shipped EDS
        for kind, pdos in (('rpdo', rpdos), ('tpdo', tpdos)):
            for pdo in pdos:
                write_pdo_the_cia_way(remote, kind, pdo)
        m.download(NODE, '23 03 18 01 83 04 00 80')  # TPDO4 off (the bridge disables unused PDOs)
        m.download(NODE, '2B C0 60 00 FE FF 00 00')  # PVT
        mark = m.send(0x000, bytes([0x01, NODE]))
        sw = None
        for controlword in (0x06, 0x07, 0x0F, 0x1F):
            mark = sniffer.mark
            m.send(0x200 + NODE, struct.pack('<Hbh', controlword, 7, 0))
            m.sync()
            tpdo1 = sniffer.wait(0x180 + NODE, mark)[0]
            sw, mode, free = struct.unpack('<HbI', tpdo1.data)
            assert len(tpdo1.data) == 7 and mode == 7 and free == 9
        assert sw == 0x1237, 'operation enabled, interpolation active'
        start = struct.unpack('<ii', sniffer.frames(0x280 + NODE)[-1].data)[0]

        def point(position: int, time_ms: int, velocity: int) -> tuple[int, int, int]:
            mark = sniffer.mark
            m.send(0x300 + NODE, struct.pack('<iI', position, time_ms))
            m.send(0x400 + NODE, struct.pack('<i', velocity))
            m.sync()
            sw, _mode, free = struct.unpack('<HbI', sniffer.wait(0x180 + NODE, mark)[0].data)
            position = struct.unpack('<ii', sniffer.wait(0x280 + NODE, mark)[0].data)[0]
            return sw, free, position

        assert point(start + 5000, 40, 0)[1] == 8, 'the running point holds a place'
        assert point(start + 5000, 0, 0)[1] == 7, 'the end point queues behind it'
        mark = sniffer.mark
        for _ in range(20):  # 40 ms of motion, and more
            m.sync()
            time.sleep(0.005)
        sw, _mode, free = struct.unpack('<HbI', sniffer.wait(0x180 + NODE, mark, count=20)[-1].data)
        assert free == 9 and sw == 0x1637, 'motion ended: target reached'
        assert struct.unpack('<ii', sniffer.wait(0x280 + NODE, mark, count=20)[-1].data)[0] == start + 5000
        assert not sniffer.frames(0x80 + NODE), 'no EMCY'


def test_bridge_boots_the_example_and_feeds_pvt_places_from_tpdo() -> None:
    data = yaml.safe_load(EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('akdbridge')
    config = parse_bus_config(copy.deepcopy(data), 'akd_pvt_example.yaml', EXAMPLE.parent)
    with running(config) as (master, sim):
        axis = master.axes['joint1']
        axis.enable(timeout=2.0)
        axis.set_mode('ip')
        drive = sim.drive(1)
        assert drive.axis().state is State.OPERATION_ENABLED
        assert drive.value(0x60C0) == -2 and drive.axis_akd.interpolation_period() == pytest.approx(0.004)
        eventually(lambda: axis.interpolation_free_slots() == 9, 1.0, '0x60C4:2 from TPDO1')
        # time_units: ms, the AKD PVT time unit
        axis.push_interpolation_point(position=drive.axis().position + 1000, time_units=20, velocity=0)
        eventually(lambda: axis.interpolation_free_slots() == 8, 1.0, 'one place taken (bit 4 is off)')
        snapshot = master.snapshot()
        assert snapshot.nodes[0].sdo_errors == 0 and snapshot.nodes[0].emcy == ()



def test_akd_mode_defaults_and_refused_modes(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, """
        nodes:
          akd: {node_id: 3, family: akd, axes: [{joint: a, scaling: {counts_per_revolution: 1048576}}]}
    """)
    axis = config.node('akd').axes[0]
    # the AKD has no csv/cst: its defaults are ip for position, pv for velocity, pt for effort
    assert (axis.mode, axis.position_mode, axis.velocity_mode, axis.effort_mode) == (7, 7, 3, 4)
    with pytest.raises(Exception) as caught:
        load_yaml(tmp_path, """
            nodes:
              akd: {node_id: 3, family: akd, axes: [{joint: a, velocity_mode: csv}]}
        """)
    assert "nodes.akd.axes[0].velocity_mode: family 'akd' does not accept mode csv " \
           "(it takes pp, pv, pt, hm, ip, csp), got 'csv'" in str(caught.value)


def test_the_bridge_switches_an_akd_to_modes_its_0x6502_omits() -> None:
    data = yaml.safe_load(EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('akd-modes')
    with running(parse_bus_config(data, 'akd example', EXAMPLE.parent)) as (master, _sim):
        axis = master.axes['joint1']
        axis.enable(timeout=3.0)
        for mode, code in (('pt', 4), ('csp', 8), ('ip', 7)):  # 0x6502 = 0x65 lists neither pt nor csp
            axis.set_mode(mode, timeout=3.0)
            assert axis.snapshot().mode == code
