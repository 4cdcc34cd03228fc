"""EDS/DCF loading against the real vendor files in ../shared/realdata/eds, and real
files used as a node's dcf."""
from __future__ import annotations

from pathlib import Path

import pytest

from configtools import CONFIGS, REAL_EDS
from drive_bridge.config import ConfigError, load_object_dictionary, parse_bus_config
from drive_bridge.model import PdoEntry

# objects parsed per file, from realdata/SOURCES.md (canopen 2.4.1): every file there loads,
# two of them only through the encoding fallbacks
EXPECTED_OBJECTS = {
    '605.3150.51-V-EK-3-60.eds': 75,  # CP437 byte: read as Latin-1
    '605.3150.60-B-EK-2-60.eds': 75, '605.3150.67-B-EK-2-60.eds': 111, '605.3150.68-B-EK-2-60.eds': 110,
    '605.3150.69-B-EK-2-60.eds': 111, 'C5-E-2-09.eds': 233, 'CL3-E-2-0F.eds': 234, 'CL3.eds': 206,
    'Elmo.dcf': 167, 'ElmoSimplIQ.dcf': 125, 'ISD860.eds': 81, 'Kollmorgen_RGM_V2.eds': 143, 'PRL120.eds': 79,
    'SINAMICS_S120_V48__SINAMICS_S120.eds': 17,  # UTF-8 BOM; modular file, few top-level objects
    'SINAMICS_S120_V48__SINAMICS_SERVO.eds': 32, 'Schunk_0_63.dcf': 98, 'epos2_347717.eds': 157,
    'maxon_epos4_0x1018.eds': 164, 'sinamics_s120.eds': 117, 'technosoft.eds': 175,
}
REAL_FILES = sorted(p.name for p in REAL_EDS.iterdir()) if REAL_EDS.is_dir() else []


def test_realdata_is_present() -> None:
    assert REAL_FILES, f'no real EDS files in {REAL_EDS} (the repository expects ../shared beside it)'


@pytest.mark.parametrize('name', REAL_FILES)
def test_every_real_file_loads_or_is_refused_with_a_reason(name: str) -> None:
    path = REAL_EDS / name
    expected = EXPECTED_OBJECTS.get(name)
    if expected is None:  # a file added after this test was written: a clear answer either way
        try:
            assert len(load_object_dictionary(path, 5)) > 0
        except ConfigError as exc:
            assert str(exc).startswith(f'{path}: {name} ')
        return
    od = load_object_dictionary(path, 5)
    assert len(od) == expected


def test_node_id_resolves_in_real_files() -> None:
    od = load_object_dictionary(REAL_EDS / 'technosoft.eds', 5)
    assert od.get_variable(0x1400, 1).default == 0x205  # type: ignore[union-attr]  # $NODEID+0x200


def test_files_that_are_not_object_dictionaries_are_refused(tmp_path: Path) -> None:
    (tmp_path / 'notes.txt').write_text('[1000]\nParameterName=x\n')
    (tmp_path / 'empty.eds').write_text('[FileInfo]\nFileName=empty.eds\n[DeviceInfo]\nVendorName=x\n')
    (tmp_path / 'binary.dcf').write_bytes(bytes(range(256)))
    for name, reason in [
        ('notes.txt', 'notes.txt is not an EDS/DCF file (expected the extension .eds or .dcf)'),
        ('empty.eds', 'empty.eds defines no objects (is it an EDS/DCF?)'),
        ('missing.eds', f'file not found (looked for {tmp_path / "missing.eds"})'),
    ]:
        with pytest.raises(ConfigError) as caught:
            load_object_dictionary(tmp_path / name, 1)
        assert str(caught.value) == f'{tmp_path / name}: {reason}'
        assert caught.value.issues[0].file == str(tmp_path / name)
    with pytest.raises(ConfigError) as caught:
        load_object_dictionary(tmp_path / 'binary.dcf', 1)
    assert str(caught.value).startswith(f'{tmp_path / "binary.dcf"}: binary.dcf is not a readable EDS/DCF: ')


def _bus(nodes: dict) -> dict:
    return {'master': {'sync_period': 4000}, 'nodes': nodes}


def test_real_eds_with_family_defaults_and_explicit_pdos() -> None:
    config = parse_bus_config(_bus({
        'ipos': {'node_id': 3, 'dcf': 'technosoft.eds',
                 'axes': [{'joint': 'wheel', 'scaling': {'counts_per_revolution': 2000, 'rated_torque': 0.3}}],
                 'sdo': [{'index': 0x60C2, 'sub_index': 1, 'value': 4},
                         {'index': 0x6098, 'sub_index': 0, 'value': 35}]},
        'gold': {'node_id': 4, 'dcf': 'Elmo.dcf',
                 'axes': [{'joint': 'lift', 'scaling': {'counts_per_revolution': 4096, 'rated_torque': 1.0}}],
                 'rpdo': {1: {'mapping': [{'index': 0x6040, 'sub_index': 0}, {'index': 0x60FF, 'sub_index': 0}]}},
                 'tpdo': {1: {'mapping': [{'index': 0x6041, 'sub_index': 0}, {'index': 0x6064, 'sub_index': 0}]},
                          3: {'cob_id': 0x384, 'transmission': 254, 'inhibit_time': 10,
                              'mapping': [{'index': 0x60F4, 'sub_index': 0}]}}},
    }), 'drives.yaml', REAL_EDS)
    ipos, gold = config.node('ipos'), config.node('gold')
    assert ipos.eds_path == REAL_EDS / 'technosoft.eds'
    # family default: two RPDOs and two TPDOs per axis, plus RPDO3 with 0x60C1:1 on a one-axis node
    assert [p.cob_id for p in ipos.rpdo] == [0x203, 0x303, 0x403] and [p.cob_id for p in ipos.tpdo] == [0x183, 0x283]
    assert ipos.tpdo[0].mapping == (PdoEntry(0x6041, 0, 16), PdoEntry(0x6061, 0, 8), PdoEntry(0x6077, 0, 16))
    assert [(i.index, i.subindex, i.value) for i in ipos.boot_sdo] == [(0x60C2, 1, 4), (0x6098, 0, 35)]
    assert [(p.number, p.cob_id, p.bits) for p in gold.rpdo] == [(1, 0x204, 48)]
    assert [(p.number, p.cob_id, p.transmission, p.inhibit_time, p.bits) for p in gold.tpdo] == [
        (1, 0x184, 1, 0, 48), (3, 0x384, 254, 10, 32)]
    # the one warning: Elmo.dcf's limit on 0x1016:01 contradicts CiA 301 (test_any402_elmo.py)
    assert [w.split(': ')[1] for w in config.warnings] == ['nodes.gold']


def test_real_eds_lacking_a_mapped_object() -> None:
    # the flat SINAMICS S120 EDS has no position modes: no 0x607A target position
    with pytest.raises(ConfigError) as caught:
        parse_bus_config(_bus({'s120': {
            'node_id': 2, 'family': 'generic_301', 'dcf': 'sinamics_s120.eds',
            'rpdo': {1: {'mapping': [{'index': 0x6040, 'sub_index': 0}, {'index': 0x607A, 'sub_index': 0}]}}}}),
            'drives.yaml', REAL_EDS)
    assert str(caught.value) == ('drives.yaml: nodes.s120.rpdo.1.mapping[1]: object 0x607A:00 (target position) '
                                 'is not in sinamics_s120.eds')


def test_real_eds_lacking_a_core_402_object() -> None:
    with pytest.raises(ConfigError) as caught:
        parse_bus_config(_bus({'s120': {'node_id': 2, 'dcf': 'sinamics_s120.eds'}}), 'drives.yaml', REAL_EDS)
    assert str(caught.value) == ('drives.yaml: nodes.s120: object 0x6064 position actual value is not in '
                                 'sinamics_s120.eds (every CiA 402 axis needs it)')


def test_real_eds_limits_and_mappability() -> None:
    with pytest.raises(ConfigError) as caught:
        parse_bus_config(_bus({'gold': {
            'node_id': 4, 'dcf': 'Elmo.dcf', 'axes': [],
            'sdo': [{'index': 0x60C2, 'sub_index': 1, 'value': 0}],
            'tpdo': {3: {'mapping': [{'index': 0x607C, 'sub_index': 0}], 'cob_id': 0x384}}}}), 'drives.yaml', REAL_EDS)
    assert caught.value.issues == [
        ('drives.yaml', 'nodes.gold.sdo[0].value',
         'expected an integer 1..255 (UNSIGNED8, LowLimit in Elmo.dcf), got 0 for object 0x60C2:01 '
         "'interpolation_time_period.interpolation_time_period_value'"),
        ('drives.yaml', 'nodes.gold.tpdo.3.mapping[0]',
         "object 0x607C:00 'home_offset' is not PDO-mappable in Elmo.dcf"),
    ]


def test_real_fixed_mapping_drive() -> None:
    # Kollmorgen RGM: read-only mapping parameters, and no 0x1A01 at all: the generic family picks
    # the fixed PDOs that carry what it needs (test_any402.py runs it)
    config = parse_bus_config(_bus({'rgm': {'node_id': 2, 'dcf': 'Kollmorgen_RGM_V2.eds',
                                            'axes': [{'joint': 'j', 'scaling': {'rated_torque': 1.0}}]}}),
                              'drives.yaml', REAL_EDS)
    rgm = config.node('rgm')
    assert [(p.number, p.cob_id, [(e.index, e.bits) for e in p.mapping]) for p in rgm.rpdo] == [
        (3, 0x402, [(0x6040, 16), (0x607A, 32)])]
    assert [p.number for p in rgm.tpdo] == [3, 4]
    assert rgm.polled == ((0x6061, 0), (0x6077, 0))


def test_fixed_mapping_accepted_when_configured_as_it_is() -> None:
    # an older FAULHABER (the CP437 file): TPDO 1 is fixed to the statusword
    config = parse_bus_config(_bus({'mcbl': {
        'node_id': 2, 'family': 'generic_301', 'dcf': '605.3150.51-V-EK-3-60.eds',
        'tpdo': {1: {'mapping': [{'index': 0x6041, 'sub_index': 0}]}}}}), 'drives.yaml', REAL_EDS)
    assert config.node('mcbl').tpdo[0].mapping == (PdoEntry(0x6041, 0, 16),)
    assert config.warnings == ('drives.yaml: nodes.mcbl.dcf: 605.3150.51-V-EK-3-60.eds is not UTF-8 '
                               '(byte 0x94 at offset 950); read as Latin-1',
                               'drives.yaml: nodes.mcbl: 605.3150.51-V-EK-3-60.eds has no 0x1017 (producer heartbeat '
                               'time): the node is guarded instead (guard_time_ms 100, life_time_factor 3)')
    with pytest.raises(ConfigError) as caught:  # the controlword is mappable, but not into this TPDO
        parse_bus_config(_bus({'mcbl': {
            'node_id': 2, 'family': 'generic_301', 'dcf': '605.3150.51-V-EK-3-60.eds',
            'tpdo': {1: {'mapping': [{'index': 0x6040, 'sub_index': 0}]}}}}), 'drives.yaml', REAL_EDS)
    assert caught.value.issues == [(
        'drives.yaml', 'nodes.mcbl.tpdo.1',
        'the mapping of TPDO 1 is fixed in 605.3150.51-V-EK-3-60.eds (0x1A00 is read-only) and holds '
        '0x6041:00 (16 bits); map exactly that or use another PDO')]


def test_canopen_warnings_about_a_file_become_config_warnings() -> None:
    config = parse_bus_config(_bus({'rgm': {'node_id': 2, 'family': 'generic_301', 'dcf': 'Kollmorgen_RGM_V2.eds'}}),
                              'drives.yaml', REAL_EDS)
    (warning,) = config.warnings
    assert warning.startswith('drives.yaml: nodes.rgm.dcf: Kollmorgen_RGM_V2.eds: canopen: SOFTWARE PARAMETERS 2 '
                              'has an unknown or unsupported data type (0x42); ')


def test_dcf_path_options_and_per_node(tmp_path: Path) -> None:
    config = parse_bus_config({'options': {'dcf_path': str(REAL_EDS)}, 'nodes': {
        'ipos': {'node_id': 3, 'dcf': 'technosoft.eds', 'axes': []},
        'io': {'node_id': 9, 'family': 'generic_301', 'dcf': 'io_module.eds', 'dcf_path': str(CONFIGS)}}},
        'drives.yaml', tmp_path)
    assert config.node('ipos').eds_path == REAL_EDS / 'technosoft.eds'
    assert config.node('io').eds_path == CONFIGS / 'io_module.eds'
    with pytest.raises(ConfigError) as caught:
        parse_bus_config({'options': {'dcf_path': 'eds'}, 'nodes': {}}, 'drives.yaml', tmp_path)
    assert str(caught.value) == f'drives.yaml: options.dcf_path: directory not found (looked for {tmp_path / "eds"})'
