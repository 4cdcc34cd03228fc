"""The bus config's ``access`` section: its shapes, its defaults and its errors (no ROS, no bus)."""
from __future__ import annotations

from pathlib import Path

from configtools import load_yaml, problems
from drive_bridge.access_rules import AccessConfig, ObjectRange

NODES = """
nodes:
  left: {node_id: 3, axes: []}
  right: {node_id: 5, axes: []}
"""


def test_defaults_close_communication_objects_saves_and_unconfigured_nmt(tmp_path: Path) -> None:
    access = load_yaml(tmp_path, NODES).access
    assert access == AccessConfig()
    assert not access.read_only
    assert access.sdo_read.allows(3, 0x1000) and access.sdo_read.allows(50, 0x1018)
    assert access.sdo_write.allows(3, 0x2000) and access.sdo_write.allows(3, 0x6040)
    assert not access.sdo_write.allows(3, 0x1017) and not access.sdo_write.allows(3, 0x1FFF)
    assert not access.store_restore.allows(3, {3, 5})
    assert access.nmt.allows(3, {3, 5}) and not access.nmt.allows(0, {3, 5}) and not access.nmt.allows(9, {3, 5})
    assert access.param_write.allows(5, {3, 5}) and not access.param_save.allows(5, {3, 5})


def test_rules_per_node_by_name_or_id_with_a_default(tmp_path: Path) -> None:
    access = load_yaml(tmp_path, NODES + """
access:
  sdo_write: {default: ["0x6000-0x6FFF"], left: ["0x1017", 0x2000, "0x2100 - 0x21FF"], 5: true}
  sdo_read: [0x6000-0x6FFF]
  nmt: true
  store_restore: [right, 7]
  param_write: false
  param_save: configured
""").access
    assert access.sdo_write.ranges(3) == (ObjectRange(0x1017, 0x1017), ObjectRange(0x2000, 0x2000),
                                          ObjectRange(0x2100, 0x21FF))
    assert access.sdo_write.allows(5, 0x1010) and access.sdo_write.allows(9, 0x6040)
    assert not access.sdo_write.allows(9, 0x2000) and not access.sdo_read.allows(3, 0x1000)
    assert access.nmt.allows(0, ()) and access.nmt.allows(99, ())
    assert access.store_restore.node_ids == {5, 7}
    assert not access.param_write.allows(3, {3, 5}) and access.param_save.allows(3, {3, 5})
    assert str(access.sdo_write.ranges(3)[2]) == '0x2100-0x21FF' and str(access.store_restore) == 'nodes 5, 7'


def test_every_error_names_its_path(tmp_path: Path) -> None:
    assert problems(tmp_path, NODES + """
access:
  sdo_write: {lefty: [], 200: [], default: ["0x6FFF-0x6000", "zz", 0x10000]}
  sdo_read: 3
  nmt: some
  param_save: [left, 0]
  readonly: true
""") == [
        "drives.yaml: access.readonly: unknown key (did you mean 'read_only'?); allowed keys: nmt, param_read, "
        'param_save, param_write, read_only, safety_objects, sdo_read, sdo_write, store_restore',
        "drives.yaml: access.sdo_read: expected true, false or a list of an index (0x6040) or a range "
        "\"0x6000-0x6FFF\", got 3",
        "drives.yaml: access.sdo_write.lefty: expected a node name or id 1..127, got 'lefty' (did you mean 'left'?); "
        'the nodes are: left, right',
        'drives.yaml: access.sdo_write.200: expected a node name or id 1..127, got 200; the nodes are: left, right',
        "drives.yaml: access.sdo_write.default[0]: range '0x6FFF-0x6000' ends before it starts; write the lower "
        'index first',
        'drives.yaml: access.sdo_write.default[1]: expected an index (0x6040) or a range "0x6000-0x6FFF" within '
        "0x0000..0xFFFF, got 'zz'",
        'drives.yaml: access.sdo_write.default[2]: expected an index (0x6040) or a range "0x6000-0x6FFF" within '
        '0x0000..0xFFFF, got 65536',
        "drives.yaml: access.nmt: expected true, false, 'configured' or a list of node names and ids, got 'some'",
        'drives.yaml: access.param_save[1]: expected a node name or id 1..127, got 0; the nodes are: left, right',
    ]


def test_read_only_warns_about_write_rules_it_overrides(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, NODES + 'access: {read_only: true, nmt: true}\n')
    assert config.access.read_only
    assert config.warnings == ('drives.yaml: access.nmt: has no effect: access.read_only refuses every write',)
