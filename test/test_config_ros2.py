"""A ros2_canopen bus.yml loads; what it says that drive_bridge ignores is reported."""
from __future__ import annotations

from pathlib import Path

import pytest

from configtools import CONFIGS, REAL_EDS, load_yaml, problems
from drive_bridge.config import load_bus_config
from drive_bridge.model import BusConfig, PdoEntry

BUS_YML = CONFIGS / 'ros2_canopen_bus.yml'


@pytest.fixture(scope='module')
def bus() -> BusConfig:
    return load_bus_config(BUS_YML)


def test_ignored_keys_are_warnings_naming_file_and_path(bus: BusConfig) -> None:
    component = 'ros2_canopen component setting; drive_bridge runs no ros2_canopen components'
    driver = 'ros2_canopen driver setting with no meaning in drive_bridge'
    assert bus.warnings == (
        f'{BUS_YML}: master.driver: ignored: {component}',
        f'{BUS_YML}: master.package: ignored: {component}',
        f'{BUS_YML}: master.start_all_nodes: ignored: lely master DCF setting; drive_bridge configures '
        'its master from this file itself',
        f'{BUS_YML}: defaults.package: ignored: {component}',
        f'{BUS_YML}: defaults.polling: ignored: {driver}',
        f'{BUS_YML}: defaults.period: ignored: {driver}',
        f'{BUS_YML}: nodes.wheel.switching_state: ignored: {driver}',
        f'{BUS_YML}: nodes.io.package: ignored: {component}',
        f'{BUS_YML}: nodes.io.rpdo.1.event_deadline: ignored: lely RPDO deadline extension; drive_bridge '
        'does not monitor RPDO deadlines',
    )


def test_master_in_ros2_canopen_units(bus: BusConfig) -> None:
    assert bus.master.node_id == 1
    assert bus.master.sync_period == pytest.approx(0.010)  # 10000 us
    assert bus.bus.bitrate == 1_000_000  # master.baudrate 1000 kbit/s
    assert bus.bus.interface == 'virtual'


def test_drivers_map_to_families(bus: BusConfig) -> None:
    assert [(n.name, n.family) for n in bus.nodes] == [
        ('wheel', 'generic_402'), ('arm', 'generic_402'), ('io', 'generic_301')]
    wheel = bus.node('wheel')
    assert wheel.eds_path == CONFIGS / '../../../../shared/realdata/eds/technosoft.eds'  # @BUS_CONFIG_PATH@
    assert wheel.eds_path.resolve() == (REAL_EDS / 'technosoft.eds').resolve()
    assert bus.node('io').eds_path == CONFIGS / 'io_module.eds'
    assert bus.node('io').reset_communication is False
    assert bus.node('io').axes == ()
    assert wheel.timeouts.sdo == pytest.approx(0.05) and wheel.timeouts.boot == pytest.approx(2.0)
    assert wheel.timeouts.homing == 15.0


def test_single_axis_driver_node_with_linear_scaling(bus: BusConfig) -> None:
    (axis,) = bus.node('wheel').axes
    assert (axis.joint, axis.slot) == ('wheel', 0)  # one axis named after the node
    assert (axis.position_mode, axis.velocity_mode) == (7, 3)
    factor = 9.587379924285257e-05
    assert axis.scaling.position_factor == factor
    assert axis.scaling.position_offset == pytest.approx(-1000 * factor)  # offset_pos_to_dev, device units
    assert axis.scaling.velocity_factor == factor
    assert axis.scaling.effort_factor == 0.001  # ros2_canopen's default for scale_eff_from_dev


def test_channels_with_per_channel_overrides(bus: BusConfig) -> None:
    lift, tilt = bus.node('arm').axes
    assert [(a.joint, a.slot) for a in (lift, tilt)] == [('arm_lift', 0), ('arm_tilt', 1)]
    assert (lift.scaling.position_factor, lift.scaling.velocity_factor) == (0.0005, 0.001)
    assert (tilt.scaling.position_factor, tilt.scaling.position_offset, tilt.scaling.velocity_factor) == \
        (0.001, 0.1, 0.002)
    eds_path = bus.node('arm').eds_path
    assert eds_path is not None and eds_path.name == 'generic402_2axis.eds'
    assert [p.cob_id for p in bus.node('arm').rpdo] == [0x204, 0x304, 0x404, 0x504]


def test_lely_pdo_and_sdo_syntax(bus: BusConfig) -> None:
    wheel, io = bus.node('wheel'), bus.node('io')
    assert [(i.index, i.subindex, i.value) for i in wheel.boot_sdo] == [
        (0x60C2, 1, 10), (0x60C2, 2, -3), (0x6098, 0, 35)]
    assert [(p.number, p.cob_id, p.transmission) for p in wheel.rpdo + wheel.tpdo] == [
        (1, 0x203, 1), (2, 0x303, 1), (1, 0x183, 1), (2, 0x283, 1)]
    assert wheel.tpdo[1].mapping == (PdoEntry(0x6064, 0, 32), PdoEntry(0x606C, 0, 32))
    assert [(p.cob_id, p.transmission, p.event_timer, p.mapping) for p in io.tpdo] == [
        (0x189, 255, 100, (PdoEntry(0x6000, 1, 8),))]
    assert io.rpdo[0].mapping == (PdoEntry(0x6200, 1, 8),)


def test_driver_node_without_scale_keys_uses_ros2_canopen_defaults(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, """
        nodes:
          joint_1: {node_id: 2, driver: "ros2_canopen::LifecycleCia402Driver", num_channels: 2}
    """, name='bus.yml')
    first, second = config.node('joint_1').axes
    assert (first.joint, second.joint) == ('joint_1_0', 'joint_1_1')
    assert (first.scaling.position_factor, first.scaling.velocity_factor, first.scaling.effort_factor) == \
        (0.001, 0.001, 0.001)
    assert config.warnings == ("bus.yml: nodes.joint_1: no scale keys: ros2_canopen's defaults apply "
                               '(scale_pos_from_dev, scale_vel_from_dev, scale_eff_from_dev = 0.001)',)


def test_family_beats_driver_with_a_warning(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, f"""
        nodes:
          io: {{node_id: 2, driver: "ros2_canopen::Cia402Driver", family: generic_301, dcf: {CONFIGS}/io_module.eds}}
    """)
    assert config.node('io').family == 'generic_301'
    assert config.warnings == ('drives.yaml: nodes.io.driver: ignored: family (nodes.io.family) takes precedence',)


def test_defaults_scale_keys_do_not_break_proxy_nodes(tmp_path: Path) -> None:
    (tmp_path / 'io_module.eds').write_bytes((CONFIGS / 'io_module.eds').read_bytes())
    config = load_yaml(tmp_path, """
        defaults: {scale_pos_from_dev: 0.01}
        nodes:
          io: {node_id: 2, driver: "ros2_canopen::ProxyDriver", dcf: io_module.eds}
    """)
    assert config.node('io').axes == ()
    assert config.warnings == ("drives.yaml: defaults.scale_pos_from_dev: not used: family 'generic_301' has no "
                               "CiA 402 axes (inherited from defaults by node 'io')",)


def test_baudrate_disagreeing_with_bitrate(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        bus: {bitrate: 500000}
        master: {baudrate: 1000}
        nodes: {}
    """) == ['drives.yaml: master.baudrate: 1000 kbit/s disagrees with bus.bitrate 500000 bit/s; '
             'give only bus.bitrate']


def test_channel_names_must_match_num_channels(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          arm: {node_id: 2, num_channels: 2, channel_names: [a, b, c], scale_pos_from_dev: 0.001}
    """) == ['drives.yaml: nodes.arm.channel_names: expected 2 names (num_channels: 2), got 3']
