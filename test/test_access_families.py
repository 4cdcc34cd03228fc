"""Which writes store or restore parameters, and which decide a drive's reaction to a lost
master or change its link, as each drive family answers (the hooks the ``access.store_restore``,
``access.param_save`` and ``access.safety_objects`` rules ask; no bus)."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from canopen import ObjectDictionary

from drive_bridge.families import get_family
from drive_bridge.families.akd.parameters import AkdParameters
from drive_bridge.families.opendrive.parameters import OpenDriveParameters
from drive_bridge.families.s120.parameters import S120Parameters
from drive_bridge.families.servostar.parameters import ServostarParameters
from drive_bridge.model import AxisConfig, NodeConfig

CONFIG = Path(__file__).resolve().parent.parent / 'config'


class Port:
    """A parameter port that is never used: the question is answered from names alone."""

    node_id = 5
    name = 'drive'

    def sdo_read_raw(self, index: int, subindex: int) -> bytes:
        raise AssertionError('no SDO expected')

    def sdo_write_raw(self, index: int, subindex: int, data: bytes) -> None:
        raise AssertionError('no SDO expected')


def node(family: str, **drive: object) -> NodeConfig:
    axes = (AxisConfig('j', drive=drive),) if drive else ()
    return NodeConfig('drive', 5, family, ObjectDictionary(), axes=axes)


@pytest.mark.parametrize('family, stores, plain', [
    ('generic_402', [(0x1010, 1), (0x1011, 1)], [(0x1017, 0), (0x2000, 0), (0x6040, 0)]),
    ('generic_301', [(0x1010, 2)], [(0x1018, 1)]),
    ('akd', [(0x1010, 1), (0x35EB, 0), (0x2026, 1)], [(0x2026, 2), (0x3501, 0), (0x6060, 0)]),
    ('sinamics_s120', [(0x1011, 1), (0x23CB, 0), (0x23D1, 0), (0x23CA, 0), (0x23D0, 0)], [(0x27D0, 0), (0x41B6, 0)]),
    ('servostar', [(0x1010, 2), (0x35EB, 1), (0x3583, 1), (0x35E9, 1)], [(0x3556, 1), (0x3501, 1)]),
])
def test_each_family_names_its_store_objects(family: str, stores: list[tuple[int, int]],
                                             plain: list[tuple[int, int]]) -> None:
    config = node(family)
    assert all(get_family(family).stores_parameters(config, *obj) for obj in stores)
    assert not any(get_family(family).stores_parameters(config, *obj) for obj in plain)


def test_opendrive_c63_follows_the_array_offset() -> None:
    family = get_family('opendrive')
    assert family.stores_parameters(node('opendrive', array_offset=1), 0x200E, 64)
    assert not family.stores_parameters(node('opendrive', array_offset=1), 0x200E, 63)
    assert family.stores_parameters(node('opendrive', array_offset=0), 0x200E, 63)
    unknown = node('opendrive')
    assert family.stores_parameters(unknown, 0x200E, 63) and family.stores_parameters(unknown, 0x200E, 64)
    assert not family.stores_parameters(unknown, 0x200D, 63)


def test_parameter_accesses_name_their_save_and_load_commands() -> None:
    port = Port()
    akd = AkdParameters(port)
    assert akd.stores('DRV.NVSAVE') and akd.stores(' drv.nvload ') and not akd.stores('DRV.ACC')
    s120 = S120Parameters(port, lambda slot: 2)
    assert s120.stores('p0977') and s120.stores('p971') and s120.stores('P0976[0]') and not s120.stores('p2000')
    servostar = ServostarParameters(port)
    assert servostar.stores('save') and servostar.stores('RSTVAR') and not servostar.stores('VLIM')
    opendrive = OpenDriveParameters(port, 0)
    assert opendrive.stores('C63') and not opendrive.stores('P63') and not opendrive.stores('C62')


@pytest.mark.parametrize('family, safety, plain', [
    ('generic_402', [(0x6007, 0), (0x6807, 0), (0x1005, 0), (0x100C, 0), (0x100D, 0), (0x1016, 1), (0x1017, 0),
                     (0x1029, 1)], [(0x6040, 0), (0x2000, 0), (0x1018, 1)]),
    ('akd', [(0x6007, 0), (0x36E5, 0), (0x36E8, 0)], [(0x3501, 0), (0x2026, 1)]),
    ('sinamics_s120', [(0x6007, 0), (0x41C1, 0), (0x419A, 0), (0x419C, 0), (0x419E, 0), (0x41A1, 0), (0x41AC, 0),
                       (0x41AE, 0)], [(0x27D0, 0), (0x41B6, 0)]),
    ('servostar', [(0x100C, 0), (0x3505, 1), (0x3515, 1)], [(0x3556, 1), (0x3501, 1)]),
])
def test_each_family_names_its_safety_objects(family: str, safety: list[tuple[int, int]],
                                              plain: list[tuple[int, int]]) -> None:
    """The objects that decide a drive's reaction to a lost master or change its link (issue 20)."""
    config = node(family)
    assert all(get_family(family).safety_object(config, *obj) for obj in safety), family
    assert not any(get_family(family).safety_object(config, *obj) for obj in plain), family


def test_opendrive_safety_parameters_follow_the_array_offset() -> None:
    family = get_family('opendrive')
    drive = yaml.safe_load((CONFIG / 'opendrive_example.yaml').read_text())['nodes']['opendrive']['axes'][0]['drive']
    zero, one = node('opendrive', **{**drive, 'array_offset': 0}), node('opendrive', **{**drive, 'array_offset': 1})
    assert 'node id' in (family.safety_object(zero, 0x200D, 162) or '')
    assert 'bit rate' in (family.safety_object(zero, 0x200E, 48) or '')
    assert family.safety_object(one, 0x200D, 163) and family.safety_object(one, 0x200E, 49)
    assert not family.safety_object(one, 0x200D, 162)


def test_parameter_accesses_name_their_safety_parameters() -> None:
    port = Port()
    akd = AkdParameters(port)
    assert akd.safety('FBUS.PARAM01') and akd.safety(' fbus.param04 ') and not akd.safety('DRV.ACC')
    s120 = S120Parameters(port, lambda slot: 2)
    assert all(s120.safety(f'p{n}') for n in (8641, 8602, 8604, 8606, 8609, 8620, 8622))
    assert not s120.safety('p2000')
    servostar = ServostarParameters(port)
    assert servostar.safety('ADDR') and servostar.safety('cbaud') and not servostar.safety('VLIM')
    opendrive = OpenDriveParameters(port, 0)
    assert opendrive.safety('P162') and opendrive.safety('C48') and not opendrive.safety('P163')
