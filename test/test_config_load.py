"""Valid configurations load into the expected typed values (no ROS needed)."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

from configtools import CONFIGS, load_yaml
from drive_bridge.config import load_bus_config, load_bus_config_text, parse_bus_config
from drive_bridge.model import BusConfig, PdoEntry

COMPLETE = CONFIGS / 'complete.yaml'


@pytest.fixture(scope='module')
def complete() -> BusConfig:
    return load_bus_config(COMPLETE)


def test_bus_master_and_simulation(complete: BusConfig) -> None:
    assert complete.path == COMPLETE
    assert complete.bus.interface == 'virtual'
    assert complete.bus.channel == 'cell_bus'
    assert complete.bus.bitrate == 500_000
    assert dict(complete.bus.options) == {'receive_own_messages': False}
    master = complete.master
    assert (master.node_id, master.sync_producer, master.heartbeat_producer_ms) == (120, 'bridge', 50)
    assert master.sync_period == pytest.approx(0.005)  # 5000 us
    assert master.heartbeat_multiplier == 2.5
    assert master.heartbeat_consumer is True
    assert complete.simulation.enabled is True
    assert {k: dict(v) for k, v in complete.simulation.options.items()} == {'slide': {'stroke': 0.8}}
    assert complete.warnings == ()


def test_nodes_identity_timeouts_and_defaults_precedence(complete: BusConfig) -> None:
    assert [n.name for n in complete.nodes] == ['shoulder', 'slide']
    shoulder, slide = complete.node('shoulder'), complete.node_by_id(6)
    assert shoulder.node_id == 5 and shoulder.family == 'generic_402'
    assert shoulder.eds_path is not None and shoulder.eds_path.name == 'generic402_2axis.eds'  # two axes
    assert slide.eds_path is not None and slide.eds_path.name == 'generic402.eds'
    assert shoulder.od[0x6840].name == 'Axis 1 Controlword'
    assert shoulder.identity.vendor_id == 0x1A3 and shoulder.identity.product_code == 0x9A  # "0x9A" string
    assert shoulder.identity.serial_number is None
    assert shoulder.reset_communication is False and slide.reset_communication is True
    # defaults apply under every node; a node's own key wins
    assert shoulder.heartbeat_producer_ms == 20
    assert slide.heartbeat_producer_ms == 100
    for node in (shoulder, slide):
        assert node.timeouts.sdo == pytest.approx(0.25)
        assert node.timeouts.boot == pytest.approx(3.0)
    assert shoulder.timeouts.state_switch == pytest.approx(0.8)
    assert shoulder.timeouts.homing == 30.0 and shoulder.timeouts.command_timeout == 0.5  # model defaults
    assert slide.timeouts.command_timeout == pytest.approx(0.2)
    assert slide.timeouts.homing == pytest.approx(20.0)  # homing_timeout_seconds
    assert shoulder.where == f'{COMPLETE}: nodes.shoulder'


def test_boot_sdo_list_in_order_with_locations(complete: BusConfig) -> None:
    items = complete.node('shoulder').boot_sdo
    assert [(i.index, i.subindex, i.value) for i in items] == [(0x60C2, 1, 2), (0x60C2, 2, -3), (0x6883, 0, 0x10000)]
    assert items[2].where == f'{COMPLETE}: nodes.shoulder.sdo[2]'
    assert complete.node('slide').boot_sdo == ()


def test_physical_scaling_factors(complete: BusConfig) -> None:
    pan, lift = complete.node('shoulder').axes
    assert (pan.joint, pan.slot, pan.joint_type, pan.mode) == ('shoulder_pan', 0, 'revolute', 8)
    position = -2 * math.pi / (4096 * 100)
    assert pan.scaling.position_factor == pytest.approx(position, rel=1e-12)
    assert pan.scaling.position_offset == 0.5
    assert pan.scaling.velocity_factor == pytest.approx(position * 0.1, rel=1e-12)
    assert pan.scaling.effort_factor == pytest.approx(-2.4 / 1000 * 100)
    assert pan.scaling.position_to_si(0) == 0.5
    assert pan.scaling.position_to_device(0.5 + 4096 * 100 * position) == 4096 * 100
    assert (lift.slot, lift.velocity_mode, lift.position_mode, lift.effort_mode) == (1, 3, 8, 10)
    assert lift.scaling.position_factor == pytest.approx(2 * math.pi / (131072 * 50), rel=1e-12)
    assert lift.scaling.effort_factor == pytest.approx(0.06)
    (slide,) = complete.node('slide').axes
    assert (slide.joint_type, slide.mode) == ('prismatic', 9)
    assert slide.scaling.position_factor == pytest.approx(1e-6)
    assert slide.scaling.effort_factor == pytest.approx(0.15)


def test_limits_and_homing(complete: BusConfig) -> None:
    pan, lift = complete.node('shoulder').axes
    assert dataclasses.astuple(pan.limits)[:5] == (-3.0, 3.0, 2.0, 10.0, 200.0)
    assert (pan.limits.on_violation, pan.limits.todo) == ('halt', ())  # (): no key TODO
    assert dataclasses.astuple(pan.homing) == (35, 0.2, 0.05, 1.0, 0.25)
    assert dataclasses.astuple(lift.limits)[:5] == (-1.5, 1.5, None, None, None) and not lift.limits.todo
    assert lift.homing.method is None
    assert pan.where == f'{COMPLETE}: nodes.shoulder.axes[0]'


def test_family_default_pdos_applied(complete: BusConfig) -> None:
    shoulder = complete.node('shoulder')
    assert [(p.number, p.cob_id, p.transmission) for p in shoulder.rpdo] == [
        (1, 0x205, 1), (2, 0x305, 1), (3, 0x405, 1), (4, 0x505, 1)]
    assert [p.cob_id for p in shoulder.tpdo] == [0x185, 0x285, 0x385, 0x485]
    assert shoulder.rpdo[2].mapping == (PdoEntry(0x6840, 0, 16), PdoEntry(0x6860, 0, 8), PdoEntry(0x6871, 0, 16))
    assert shoulder.tpdo[3].mapping == (PdoEntry(0x6864, 0, 32), PdoEntry(0x686C, 0, 32))
    assert all(p.bits <= 64 for p in shoulder.rpdo + shoulder.tpdo)


def test_explicit_pdos_resolved(complete: BusConfig) -> None:
    slide = complete.node('slide')
    r1, r2 = slide.rpdo
    assert (r1.number, r1.cob_id, r1.transmission, r1.enabled) == (1, 0x206, 1, True)  # auto, sync default
    assert r1.mapping == (PdoEntry(0x6040, 0, 16), PdoEntry(0x6060, 0, 8))
    assert (r2.cob_id, r2.bits) == (0x310, 64)
    t1, t2 = slide.tpdo
    assert (t1.cob_id, t1.transmission) == (0x186, 1)
    assert (t2.cob_id, t2.transmission, t2.event_timer, t2.inhibit_time) == (0x286, 255, 10, 5)
    assert t2.mapping == (PdoEntry(0x6064, 0, 32), PdoEntry(0x606C, 0, 32))


def test_config_is_frozen(complete: BusConfig) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        complete.master.node_id = 1  # type: ignore[misc]


def test_without_sync_pdos_are_event_driven(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, """
        master: {sync_period: 0}
        nodes:
          drive:
            node_id: 7
            tpdo:
              1: {mapping: [{index: 0x6041, sub_index: 0}]}
    """)
    node = config.node('drive')
    assert config.master.sync_period == 0.0
    assert node.tpdo[0].transmission == 255  # explicit PDO without `transmission`
    assert [(p.transmission, p.event_timer) for p in node.rpdo] == [(255, 0)] * 3  # family default
    # a node with no axes section is one axis named after the node, with a warning about scaling
    assert [a.joint for a in node.axes] == ['drive']
    assert node.axes[0].scaling.position_factor == 1.0
    assert config.warnings == ('drives.yaml: nodes.drive: no scaling given: device units are passed through '
                               'unscaled (all factors 1)',)


def test_defaults_replace_whole_values_and_locate_warnings(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, """
        defaults:
          sdo: [{index: 0x6060, sub_index: 0, value: 8}]
          reset_communication: false
          polling: true
        nodes:
          a: {node_id: 1, axes: []}
          b: {node_id: 2, axes: [], sdo: [{index: 0x6098, sub_index: 0, value: 35}]}
    """)
    assert [(i.index, i.value, i.where) for i in config.node('a').boot_sdo] == [
        (0x6060, 8, 'drives.yaml: defaults.sdo[0]')]
    assert [(i.index, i.value) for i in config.node('b').boot_sdo] == [(0x6098, 35)]  # the node's list wins whole
    assert config.node('a').reset_communication is config.node('b').reset_communication is False
    assert config.node('a').axes == ()
    assert config.warnings == ('drives.yaml: defaults.polling: ignored: ros2_canopen driver setting with no '
                               'meaning in drive_bridge',)


def test_inline_config_text_and_parsed_mapping() -> None:
    text = 'nodes:\n  io:\n    node_id: 9\n    dcf: io_module.eds\n    family: generic_301\n'
    config = load_bus_config_text(text, source='<param config>', base_dir=CONFIGS)
    assert config.path is None
    assert config.node('io').od.get_variable(0x1400, 1).default == 0x209  # type: ignore[union-attr]  # $NODEID resolved with the node's id
    assert config.node('io').rpdo == () and config.node('io').tpdo == ()  # generic 301: no default map
    same = parse_bus_config({'nodes': {'io': {'node_id': 9, 'dcf': 'io_module.eds', 'family': 'generic_301'}}},
                            '<param config>', CONFIGS)
    assert same.node('io').node_id == 9 and same.warnings == ()


def test_yaml_floats_and_hex_strings(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, """
        nodes:
          d:
            node_id: 0x0A
            serial_number: "0xDEADBEEF"
            axes:
              - joint: j
                scaling: {scale_pos_from_dev: 1e-3, scale_vel_to_dev: 2e+3, scale_eff_from_dev: 5e-4}
    """)
    node = config.node('d')
    assert node.node_id == 10 and node.identity.serial_number == 0xDEADBEEF
    scaling = node.axes[0].scaling
    assert (scaling.position_factor, scaling.velocity_factor, scaling.effort_factor) == (1e-3, 1 / 2000, 5e-4)


def test_master_baudrate_sets_bitrate(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, 'master: {baudrate: 250}\nnodes: {}\n')
    assert config.bus.bitrate == 250_000
    assert config.nodes == ()
    assert config.warnings == ('drives.yaml: nodes: no nodes: the bridge will only run the master (SYNC, heartbeat)',)
