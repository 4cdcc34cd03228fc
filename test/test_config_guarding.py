"""Node guarding keys (guard_time_ms, life_time_factor): accepted, refused, and how they
share a node with heartbeat_producer. The nodes use the AKD family, whose shipped EDS has
0x100C and 0x100D (so does the generic 402 EDS)."""
from __future__ import annotations

from pathlib import Path

from configtools import load_yaml, problems
from drive_bridge.resources import family_data

AKD = '{node_id: 1, family: akd, axes: []'
AKD_EDS = family_data('akd', 'akd.eds')


def test_guard_time_alone_guards_the_node_with_factor_3_and_no_heartbeat(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, f"""
        nodes:
          servo: {AKD}, guard_time_ms: 100}}
          other: {{node_id: 2, family: akd, axes: [], life_time_factor: 4, guard_time_ms: 250}}
    """)
    servo, other = config.nodes
    assert servo.guarding
    assert (servo.guard_time_ms, servo.life_time_factor, servo.heartbeat_producer_ms) == (100, 3, 0)
    assert (other.guard_time_ms, other.life_time_factor, other.heartbeat_producer_ms) == (250, 4, 0)
    assert config.warnings == ()  # no 'the node sends no heartbeat' warning: the master guards it


def test_no_guard_time_or_0_is_the_heartbeat_as_before(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, f"""
        nodes:
          a: {AKD}}}
          b: {{node_id: 2, family: akd, axes: [], guard_time_ms: 0}}
          c: {{node_id: 3, family: akd, axes: [], guard_time_ms: 100, heartbeat_producer: 0}}
    """)
    a, b, c = config.nodes
    assert (a.heartbeat_producer_ms, a.guard_time_ms, a.life_time_factor, a.guarding) == (100, 0, 0, False)
    assert (b.heartbeat_producer_ms, b.guard_time_ms, b.guarding) == (100, 0, False)
    assert (c.heartbeat_producer_ms, c.guard_time_ms, c.guarding) == (0, 100, True)


def test_a_nodes_own_key_wins_over_the_other_one_from_defaults(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, f"""
        defaults: {{heartbeat_producer: 50}}
        nodes:
          drive: {AKD}}}
          servostar: {{node_id: 2, family: akd, axes: [], guard_time_ms: 200}}
    """)
    drive, servostar = config.nodes
    assert (drive.heartbeat_producer_ms, drive.guarding) == (50, False)
    assert (servostar.heartbeat_producer_ms, servostar.guard_time_ms, servostar.life_time_factor) == (0, 200, 3)
    config = load_yaml(tmp_path, f"""
        defaults: {{guard_time_ms: 100, life_time_factor: 5}}
        nodes:
          guarded: {AKD}}}
          beating: {{node_id: 2, family: akd, axes: [], heartbeat_producer: 20}}
    """)
    guarded, beating = config.nodes
    assert (guarded.heartbeat_producer_ms, guarded.guard_time_ms, guarded.life_time_factor) == (0, 100, 5)
    assert (beating.heartbeat_producer_ms, beating.guard_time_ms, beating.life_time_factor) == (20, 0, 0)


def test_a_life_time_factor_from_defaults_applies_to_guarded_nodes_only(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, f"""
        defaults: {{life_time_factor: 4}}
        nodes:
          plain: {AKD}}}
          guarded: {{node_id: 2, family: akd, axes: [], guard_time_ms: 100}}
    """)
    plain, guarded = config.nodes
    assert (plain.guard_time_ms, plain.life_time_factor, plain.heartbeat_producer_ms) == (0, 0, 100)
    assert (guarded.guard_time_ms, guarded.life_time_factor) == (100, 4)


def test_heartbeat_and_guarding_on_one_node_are_refused(tmp_path: Path) -> None:
    assert problems(tmp_path, f"""
        nodes:
          servo: {AKD}, heartbeat_producer: 100, guard_time_ms: 200}}
    """) == [
        "drives.yaml: nodes.servo.guard_time_ms: heartbeat and node guarding exclude each other: node 'servo' has "
        'heartbeat_producer 100 (nodes.servo.heartbeat_producer) and guard_time_ms 200; give heartbeat_producer: 0 '
        'to guard the node, or guard_time_ms: 0 to use its heartbeat']
    assert problems(tmp_path, f"""
        defaults: {{heartbeat_producer: 50, guard_time_ms: 100}}
        nodes:
          a: {AKD}}}
    """) == [
        "drives.yaml: defaults.guard_time_ms: heartbeat and node guarding exclude each other: node 'a' has "
        'heartbeat_producer 50 (defaults.heartbeat_producer) and guard_time_ms 100; give heartbeat_producer: 0 '
        "to guard the node, or guard_time_ms: 0 to use its heartbeat (inherited from defaults by node 'a')"]


def test_a_life_time_factor_without_guard_time_is_refused(tmp_path: Path) -> None:
    assert problems(tmp_path, f"""
        nodes:
          a: {AKD}, life_time_factor: 3}}
          b: {{node_id: 2, family: akd, axes: [], life_time_factor: 3, guard_time_ms: 0}}
    """) == [
        'drives.yaml: nodes.a.life_time_factor: a life time factor without node guarding: guard_time_ms is not '
        'given; give guard_time_ms 1..65535 or remove life_time_factor',
        'drives.yaml: nodes.b.life_time_factor: a life time factor without node guarding: guard_time_ms is 0 '
        '(nodes.b.guard_time_ms); give guard_time_ms 1..65535 or remove life_time_factor',
    ]


def test_out_of_range_values(tmp_path: Path) -> None:
    assert problems(tmp_path, f"""
        nodes:
          a: {AKD}, guard_time_ms: 70000, life_time_factor: 0}}
          b: {{node_id: 2, family: akd, axes: [], guard_time_ms: -1}}
          c: {{node_id: 3, family: akd, axes: [], guard_time_ms: 'fast', life_time_factor: 2}}
          d: {{node_id: 4, family: akd, axes: [], guard_time_ms: 100, life_time_factor: 256}}
          e: {{node_id: 5, family: akd, axes: [], guard_time_ms: 1.5}}
    """) == [
        'drives.yaml: nodes.a.guard_time_ms: expected an integer 0..65535, got 70000',
        'drives.yaml: nodes.a.life_time_factor: expected an integer 1..255, got 0',
        'drives.yaml: nodes.b.guard_time_ms: expected an integer 0..65535, got -1',
        "drives.yaml: nodes.c.guard_time_ms: expected an integer 0..65535, got 'fast'",  # no second error for c
        'drives.yaml: nodes.d.life_time_factor: expected an integer 1..255, got 256',
        'drives.yaml: nodes.e.guard_time_ms: expected an integer 0..65535, got 1.5',
    ]


def test_a_guarded_node_needs_writable_guard_objects_in_its_eds(tmp_path: Path) -> None:
    text = AKD_EDS.read_text(encoding='utf-8')
    without = text
    for index in ('100C', '100D'):  # an EDS without the guarding objects
        start = without.index(f'[{index}]')
        without = without[:start] + without[without.index('\n[', start + 1) + 1:]
        without = without.replace(f'=0x{index}\n', '=0x1000\n')
    (tmp_path / 'no_guard.eds').write_text(without, encoding='utf-8')
    assert problems(tmp_path, """
        nodes:
          a: {node_id: 1, family: akd, dcf: no_guard.eds, axes: [], guard_time_ms: 100}
    """) == [
        'drives.yaml: nodes.a.guard_time_ms: node guarding writes 0x100C (guard time) and 0x100D (life time factor) '
        'at boot, but object 0x100C:00 is not in no_guard.eds; object 0x100D:00 is not in no_guard.eds']
    guard_section = text.index('[100C]')
    access = text.index('AccessType=rw', guard_section)
    (tmp_path / 'fixed_guard.eds').write_text(text[:access] + 'AccessType=ro' + text[access + 13:], encoding='utf-8')
    assert problems(tmp_path, """
        nodes:
          a: {node_id: 1, family: akd, dcf: fixed_guard.eds, axes: [], guard_time_ms: 100}
    """) == [
        'drives.yaml: nodes.a.guard_time_ms: node guarding writes 0x100C (guard time) and 0x100D (life time factor) '
        "at boot, but object 0x100C:00 'Guard time' is read-only (access ro) in fixed_guard.eds"]


def test_boot_sdos_to_the_guard_objects_are_warnings(tmp_path: Path) -> None:
    config = load_yaml(tmp_path, f"""
        nodes:
          guarded: {AKD}, guard_time_ms: 100, sdo: [{{index: 0x100C, sub_index: 0, value: 100}}]}}
          ros: {{node_id: 2, family: akd, axes: [], sdo: [{{index: 0x100D, value: 3}}, {{index: 0x100C, value: 0}}]}}
    """)
    assert config.warnings == (
        'drives.yaml: nodes.guarded.sdo[0]: 0x100C is written from guard_time_ms / life_time_factor by the node '
        'guarding boot step after the boot SDOs; remove this item',
        'drives.yaml: nodes.ros.sdo[0]: 0x100D makes the node expect node guarding, but the master guards only '
        'nodes with guard_time_ms; give guard_time_ms (and life_time_factor) instead',
    )  # writing 0 (nodes.ros.sdo[1]) switches the node's life guarding off: no warning


def test_a_family_without_heartbeat_must_be_guarded(tmp_path: Path) -> None:
    from drive_bridge.families import BootTraits, DriveFamily, register_family, unregister_family

    class NoHeartbeat(DriveFamily):
        name = 'test_no_heartbeat'
        boot = BootTraits(has_heartbeat=False)
        default_eds = AKD_EDS

    register_family(NoHeartbeat)
    try:
        node = '{node_id: 1, family: test_no_heartbeat, axes: []'
        assert problems(tmp_path, f"""
            nodes:
              a: {node}}}
        """) == ["drives.yaml: nodes.a.family: family 'test_no_heartbeat' is supervised by node guarding: node 'a' "
                 'needs guard_time_ms (e.g. 100) so that the bridge notices when it is lost']
        assert problems(tmp_path, f"""
            nodes:
              a: {node}, guard_time_ms: 100, heartbeat_producer: 50}}
        """) == ["drives.yaml: nodes.a.heartbeat_producer: family 'test_no_heartbeat' is supervised by node guarding, "
                 "not heartbeat: supervise node 'a' with guard_time_ms instead"]
        config = load_yaml(tmp_path, f"""
            defaults: {{heartbeat_producer: 50}}
            nodes:
              a: {node}, guard_time_ms: 100}}
        """)
        assert (config.nodes[0].heartbeat_producer_ms, config.nodes[0].guard_time_ms) == (0, 100)
    finally:
        unregister_family('test_no_heartbeat')
