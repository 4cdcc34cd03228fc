"""Each kind of configuration error: the exact message names file, path, expectation and value.

The configs use the generic 402 family's shipped EDS, so every object fact below is a
fact of drive_bridge/families/generic402/data/generic402.eds.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from configtools import load_yaml, problems
from drive_bridge.config import ConfigError, Issue, load_bus_config, parse_bus_config

SCALED = '{counts_per_revolution: 4096, rated_torque: 1.0}'


def test_config_error_is_a_value_error_with_located_issues(tmp_path: Path) -> None:
    with pytest.raises(ValueError) as caught:
        load_yaml(tmp_path, 'nodes:\n  left: {node_id: 200}\n')
    assert isinstance(caught.value, ConfigError)
    assert caught.value.issues == [Issue('drives.yaml', 'nodes.left.node_id', 'expected an integer 1..127, got 200')]
    assert caught.value.issues[0] == ('drives.yaml', 'nodes.left.node_id', 'expected an integer 1..127, got 200')


def test_all_problems_of_a_file_are_reported_at_once(tmp_path: Path) -> None:
    lines = problems(tmp_path, """
        master: {node_id: 0, sync_period: -1}
        nodes:
          left: {node_id: 200, heartbeat_consumer: 'yes'}
    """)
    assert lines == [
        'drives.yaml: master.node_id: expected an integer 1..127, got 0',
        'drives.yaml: master.sync_period: expected an integer >= 0, got -1',
        'drives.yaml: nodes.left.node_id: expected an integer 1..127, got 200',
        "drives.yaml: nodes.left.heartbeat_consumer: expected true or false, got 'yes'",
    ]


def test_unknown_key_lists_allowed_keys_and_suggests_the_closest(tmp_path: Path) -> None:
    lines = problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: [{joint: a, scaling: {counts_per_revolution: 10, gear_ration: 3}}]
    """)
    assert lines == [
        "drives.yaml: nodes.left.axes[0].scaling.gear_ration: unknown key (did you mean 'gear_ratio'?); "
        'allowed keys: counts_per_metre, counts_per_revolution, direction, gear_ratio, offset, offset_pos_from_dev, '
        'offset_pos_to_dev, rated_torque, scale_eff_from_dev, scale_pos_from_dev, scale_pos_to_dev, '
        'scale_vel_from_dev, scale_vel_to_dev, velocity_scale']
    top = problems(tmp_path, 'node: {}\nnodes: {}\n')
    assert top == ["drives.yaml: node: unknown key (did you mean 'nodes'?); allowed keys: access, bus, defaults, "
                   'master, nodes, options, record, simulation, trajectory']


def test_wrong_types(tmp_path: Path) -> None:
    lines = problems(tmp_path, f"""
        bus: {{interface: socketcann, channel: [can0]}}
        nodes:
          left_arm:
            node_id: "five"
            axes:
              - {{joint: a, scaling: {SCALED}}}
              - {{joint: b, slot: 1, scaling: {{counts_per_revolution: 4096, gear_ratio: -3}}, limits: 3}}
    """)
    assert lines[0].startswith("drives.yaml: bus.interface: expected one of 'canalystii', ")
    assert lines[0].endswith("'virtual', got 'socketcann' (did you mean 'socketcan'?)")
    assert lines[1:] == [
        'drives.yaml: bus.channel: expected a channel name or number (can0, PCAN_USBBUS1, 0), got a list',
        "drives.yaml: nodes.left_arm.node_id: expected an integer 1..127, got 'five'",
        'drives.yaml: nodes.left_arm.axes[1].scaling.gear_ratio: expected a number > 0, got -3',
        'drives.yaml: nodes.left_arm.axes[1].limits: expected a mapping, got 3',
    ]


def test_node_id_out_of_range_and_bad_node_name(tmp_path: Path) -> None:
    assert problems(tmp_path, 'nodes:\n  2left: {node_id: 128}\n') == [
        "drives.yaml: nodes.2left: expected a node name of letters, digits and '_' starting with a letter "
        "(it becomes part of ROS names), got '2left'",
        'drives.yaml: nodes.2left.node_id: expected an integer 1..127, got 128',
    ]


def test_duplicate_node_id(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left: {node_id: 3, axes: []}
          right: {node_id: 3, axes: []}
    """) == ["drives.yaml: nodes.right.node_id: 3 is already used by node 'left' (nodes.left.node_id)"]


def test_duplicate_node_name_is_a_yaml_error_with_line(tmp_path: Path) -> None:
    assert problems(tmp_path, 'nodes:\n  left: {node_id: 1}\n  left: {node_id: 2}\n') == [
        "drives.yaml: line 3, column 3: YAML error: duplicate key 'left' (first on line 2); a later key would "
        'silently replace the earlier one']


def test_master_id_collision(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        master: {node_id: 5}
        nodes:
          left: {node_id: 5, axes: []}
    """) == ["drives.yaml: nodes.left.node_id: 5 is the master's node id (master.node_id); "
             'give the node or the master another id']
    assert problems(tmp_path, 'nodes:\n  left: {node_id: 127, axes: []}\n') == [
        "drives.yaml: nodes.left.node_id: 127 is the master's node id (the default of master.node_id); "
        'give the node or the master another id']


def test_duplicate_joint_across_nodes(tmp_path: Path) -> None:
    assert problems(tmp_path, f"""
        nodes:
          left: {{node_id: 1, axes: [{{joint: elbow, scaling: {SCALED}}}]}}
          right: {{node_id: 2, axes: [{{joint: elbow, scaling: {SCALED}}}]}}
    """) == ["drives.yaml: nodes.right.axes[0].joint: joint 'elbow' is already used by nodes.left.axes[0].joint"]


def test_duplicate_slot(tmp_path: Path) -> None:
    assert problems(tmp_path, f"""
        nodes:
          left:
            node_id: 1
            axes:
              - {{joint: a, scaling: {SCALED}}}
              - {{joint: b, slot: 0, scaling: {SCALED}}}
    """) == ["drives.yaml: nodes.left.axes[1].slot: slot 0 is already used by nodes.left.axes[0] (joint 'a')"]


def test_bad_joint_name_and_modes(tmp_path: Path) -> None:
    assert problems(tmp_path, f"""
        nodes:
          left:
            node_id: 1
            axes: [{{joint: 1st, mode: dance, velocity_mode: csp, effort_mode: 4, scaling: {SCALED}}}]
    """) == [
        "drives.yaml: nodes.left.axes[0].joint: expected a joint name (letters, digits and '_', not starting "
        "with a digit; '/' between parts), got '1st'",
        "drives.yaml: nodes.left.axes[0].mode: expected a mode name (none, pp, vl, pv, pt, hm, ip, csp, csv, cst) "
        "or a number -128..127, got 'dance'",
        'drives.yaml: nodes.left.axes[0].velocity_mode: expected a velocity mode (vl, pv, csv) or a manufacturer '
        "mode (< 0), got 'csp' (mode 8)",
    ]


def test_pdo_over_64_bits(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            rpdo:
              1:
                mapping:
                  - {index: 0x6040, sub_index: 0}
                  - {index: 0x607A, sub_index: 0}
                  - {index: 0x60FF, sub_index: 0}
    """) == ['drives.yaml: nodes.left.rpdo.1.mapping: 80 bits mapped (0x6040:00 16, 0x607A:00 32, 0x60FF:00 32); '
             'a PDO carries at most 64']


def test_pdo_object_not_mappable(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            tpdo: {1: {mapping: [{index: 0x6041, sub_index: 0}, {index: 0x6076, sub_index: 0}]}}
    """) == ["drives.yaml: nodes.left.tpdo.1.mapping[1]: object 0x6076:00 'Motor rated torque' is not "
             'PDO-mappable in generic402.eds']


def test_pdo_object_absent_from_eds(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            tpdo:
              1: {mapping: [{index: 0x2000, sub_index: 0}, {index: 0x6099, subindex: 3}]}
    """) == [
        'drives.yaml: nodes.left.tpdo.1.mapping[0]: object 0x2000:00 is not in generic402.eds',
        "drives.yaml: nodes.left.tpdo.1.mapping[1]: object 0x6099:03: 0x6099 'Homing speeds' has no sub-index 3 "
        'in generic402.eds (it has 0, 1, 2)',
    ]


def test_rpdo_mapping_a_read_only_object(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            rpdo: {1: {mapping: [{index: 0x6041, sub_index: 0}]}}
    """) == ["drives.yaml: nodes.left.rpdo.1.mapping[0]: object 0x6041:00 'Statusword' is read-only (access ro) "
             'in generic402.eds; an RPDO can only map writable objects']


def test_cob_id_collision_across_nodes(tmp_path: Path) -> None:
    assert problems(tmp_path, f"""
        nodes:
          left: {{node_id: 1, axes: [{{joint: a, scaling: {SCALED}}}]}}
          right:
            node_id: 2
            axes: []
            tpdo: {{1: {{cob_id: 0x201, mapping: [{{index: 0x6041, sub_index: 0}}]}}}}
    """) == ["drives.yaml: nodes.right.tpdo.1.cob_id: COB-ID 0x201 is already used by the family 'generic_402' "
             "default RPDO 1 of node 'left'"]
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            rpdo: {3: {cob_id: 0x481, mapping: [{index: 0x6040, sub_index: 0}]}}
          right:
            node_id: 2
            axes: []
            rpdo: {3: {cob_id: 0x481, mapping: [{index: 0x6040, sub_index: 0}]}}
    """) == ["drives.yaml: nodes.right.rpdo.3.cob_id: COB-ID 0x481 is already used by nodes.left.rpdo.3 "
             "(RPDO 3 of node 'left')"]


def test_cob_id_in_a_reserved_range(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            tpdo: {1: {cob_id: 0x701, mapping: [{index: 0x6041, sub_index: 0}]}}
            rpdo: {1: {cob_id: 0x80000201, mapping: [{index: 0x6040, sub_index: 0}]}}
    """) == [
        "drives.yaml: nodes.left.rpdo.1.cob_id: expected 'auto' or an 11-bit COB-ID 0x001..0x7FF, got 2147484161 "
        '(use enabled: false instead of bit 31)',
        'drives.yaml: nodes.left.tpdo.1.cob_id: COB-ID 0x701 is reserved for heartbeat / node guarding '
        '(0x701..0x77F)',
    ]


def test_cob_id_auto_for_pdo_5(tmp_path: Path) -> None:
    lines = problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            tpdo: {5: {cob_id: auto, mapping: [{index: 0x6041, sub_index: 0}]}}
    """)
    assert lines[0] == ("drives.yaml: nodes.left.tpdo.5.cob_id: cob_id 'auto' only works for PDOs 1..4 "
                        "(CiA 301's predefined connection set); give TPDO 5 an explicit cob_id")
    # the shipped EDS has four TPDOs, which is a second, independent problem
    assert lines[1:] == ['drives.yaml: nodes.left.tpdo.5: TPDO 5 is not available in generic402.eds: it has no '
                         '0x1804 communication parameter (4 TPDOs defined)']


def test_pdo_keys_of_the_other_direction_and_bad_transmission(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            rpdo: {1: {inhibit_time: 3, transmission: 252, mapping: [{index: 0x6040, sub_index: 0}]}}
            tpdo: {1: {event_deadline: 3, mapping: [{index: 0x6041, sub_index: 0}]}}
    """) == [
        'drives.yaml: nodes.left.rpdo.1.inhibit_time: inhibit_time applies to TPDOs only',
        'drives.yaml: nodes.left.rpdo.1.transmission: expected a transmission type 0..240 (synchronous), '
        '254 or 255 (event-driven) for an RPDO, got 252',
        'drives.yaml: nodes.left.tpdo.1.event_deadline: event_deadline applies to RPDOs only',
    ]


def test_enabled_pdo_needs_a_mapping(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            rpdo: {1: {mapping: []}, 2: {transmission: 1}, 3: {enabled: false}}
    """) == [
        'drives.yaml: nodes.left.rpdo.1.mapping: an enabled PDO needs at least one mapped object '
        '(or set enabled: false)',
        'drives.yaml: nodes.left.rpdo.2.mapping: required key is missing; expected a list of {index, sub_index}',
    ]


def test_boot_sdo_object_absent(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left: {node_id: 1, axes: [], sdo: [{index: 0x2000, sub_index: 0, value: 1}]}
    """) == ['drives.yaml: nodes.left.sdo[0]: object 0x2000:00 is not in generic402.eds']


def test_boot_sdo_object_read_only(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left: {node_id: 1, axes: [], sdo: [{index: 0x1018, sub_index: 1, value: 1}]}
    """) == ["drives.yaml: nodes.left.sdo[0]: object 0x1018:01 'Identity object.Vendor-ID' is read-only "
             '(access ro) in generic402.eds']


def test_boot_sdo_value_out_of_range(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left: {node_id: 1, axes: [], sdo: [{index: 0x6060, sub_index: 0, value: 300}]}
    """) == ["drives.yaml: nodes.left.sdo[0].value: expected an integer -128..127 (INTEGER8), got 300 for "
             "object 0x6060:00 'Modes of operation'"]


def test_boot_sdo_value_of_the_wrong_type(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: []
            sdo:
              - {index: 0x6083, sub_index: 0, value: fast}
              - {index: 0x6083, sub_index: 0, value: 1.5}
              - {index: 0x6083, sub_index: 0}
    """) == [
        "drives.yaml: nodes.left.sdo[0].value: expected an integer 0..4294967295 (UNSIGNED32), got 'fast' for "
        "object 0x6083:00 'Profile acceleration'",
        'drives.yaml: nodes.left.sdo[1].value: expected an integer 0..4294967295 (UNSIGNED32), got 1.5 for '
        "object 0x6083:00 'Profile acceleration'",
        'drives.yaml: nodes.left.sdo[2].value: required key is missing; expected the value to write',
    ]


def test_missing_eds_file_is_one_error(tmp_path: Path) -> None:
    # the SDO and PDO items cannot be checked without the EDS: no follow-up errors
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            dcf: missing.eds
            sdo: [{index: 0x2000, sub_index: 0, value: 1}]
            rpdo: {1: {mapping: [{index: 0x2001, sub_index: 0}]}}
    """) == [f'drives.yaml: nodes.left.dcf: file not found (looked for {tmp_path / "missing.eds"})']


def test_eds_that_is_not_an_eds(tmp_path: Path) -> None:
    (tmp_path / 'drive.txt').write_text('[1000]\n')
    (tmp_path / 'broken.eds').write_text('this is not an ini file\n')
    assert problems(tmp_path, """
        nodes:
          a: {node_id: 1, dcf: drive.txt, family: generic_301}
          b: {node_id: 2, dcf: broken.eds, family: generic_301}
    """) == [
        'drives.yaml: nodes.a.dcf: drive.txt is not an EDS/DCF file (expected the extension .eds or .dcf)',
        'drives.yaml: nodes.b.dcf: broken.eds is not a readable EDS/DCF: MissingSectionHeaderError: File '
        "contains no section headers. file: 'broken.eds', line: 1 'this is not an ini file\\n'",
    ]


def test_generic_301_needs_a_dcf(tmp_path: Path) -> None:
    assert problems(tmp_path, 'nodes:\n  io: {node_id: 3, family: generic_301}\n') == [
        "drives.yaml: nodes.io: no dcf given, and family 'generic_301' ships no EDS; give dcf: <file>.eds (or .dcf)"]


def test_unknown_family_and_driver(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          a: {node_id: 1, family: generic402}
          b: {node_id: 2, driver: "ros2_canopen::Cia402Drive"}
    """) == [
        "drives.yaml: nodes.a.family: expected one of 'akd', 'generic_301', 'generic_402', 'opendrive', "
        "'servostar', 'sinamics_s120', got 'generic402' (did you mean 'generic_402'?)",
        "drives.yaml: nodes.b.driver: unknown ros2_canopen driver 'ros2_canopen::Cia402Drive' (did you mean "
        "'ros2_canopen::Cia402Driver'?); drive_bridge maps ros2_canopen::Cia402Driver, "
        'ros2_canopen::LifecycleCia402Driver, ros2_canopen::MotionControllerDriver, '
        'ros2_canopen::LifecycleMotionControllerDriver, ros2_canopen::ProxyDriver, '
        'ros2_canopen::LifecycleProxyDriver; or give family: one of akd, generic_301, generic_402, opendrive, '
        'servostar, sinamics_s120',
    ]


def test_scaling_form_mixing(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes: [{joint: a, scaling: {gear_ratio: 3, scale_pos_from_dev: 0.1}}]
    """) == ['drives.yaml: nodes.left.axes[0].scaling: mixes the physical form (gear_ratio) with the '
             'ros2_canopen linear form (scale_pos_from_dev); use one of them']
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            scale_pos_to_dev: 1000
            axes: [{joint: a}]
    """) == ['drives.yaml: nodes.left.scale_pos_to_dev: cannot be combined with `axes` (nodes.left.axes); '
             'give scaling and modes in each axis section instead']


def test_non_reciprocal_scales(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            scale_pos_to_dev: 1000
            scale_pos_from_dev: 0.002
            offset_pos_to_dev: 10
            offset_pos_from_dev: 3
    """) == [
        'drives.yaml: nodes.left.scale_pos_from_dev: scale_pos_from_dev 0.002 is not the reciprocal of '
        'scale_pos_to_dev 1000 (nodes.left.scale_pos_to_dev): their product is 2, expected 1; give only one of '
        'them or make them reciprocal',
        'drives.yaml: nodes.left.offset_pos_from_dev: offset_pos_from_dev 3 disagrees with offset_pos_to_dev 10 '
        '(nodes.left.offset_pos_to_dev), which means -0.02 in SI; give only one of them',
    ]


def test_physical_scaling_checks(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        nodes:
          left:
            node_id: 1
            axes:
              - joint: a
                scaling: {counts_per_metre: 1000, direction: 2, rated_torque: 0}
                limits: {min_position: 1.0, max_position: -1.0, max_velocity: 0}
                homing: {method: 200}
    """) == [
        'drives.yaml: nodes.left.axes[0].scaling.counts_per_metre: counts_per_metre is for prismatic joints; '
        'this joint is revolute (use counts_per_revolution)',
        'drives.yaml: nodes.left.axes[0].scaling.direction: expected 1 or -1, got 2',
        'drives.yaml: nodes.left.axes[0].scaling.rated_torque: expected a number > 0, got 0',
        'drives.yaml: nodes.left.axes[0].limits.max_position: expected a number > min_position (1), got -1.0',
        'drives.yaml: nodes.left.axes[0].limits.max_velocity: expected a number > 0, got 0',
        'drives.yaml: nodes.left.axes[0].homing.method: expected an integer -128..127, got 200',
    ]


def test_too_many_axes_for_the_family(tmp_path: Path) -> None:
    assert problems(tmp_path, f"""
        nodes:
          left:
            node_id: 1
            axes:
              - {{joint: a, scaling: {SCALED}}}
              - {{joint: b, scaling: {SCALED}}}
              - {{joint: c, scaling: {SCALED}}}
    """) == ["drives.yaml: nodes.left.axes: 3 axes, but family 'generic_402' drives at most 2 with its default "
             'PDO map; give explicit rpdo and tpdo for up to 8']


def test_axes_on_a_generic_301_node(tmp_path: Path) -> None:
    (tmp_path / 'io.eds').write_bytes((Path(__file__).parent / 'data' / 'configs' / 'io_module.eds').read_bytes())
    assert problems(tmp_path, """
        nodes:
          io: {node_id: 3, family: generic_301, dcf: io.eds, axes: [{joint: a}]}
    """) == ["drives.yaml: nodes.io.axes: family 'generic_301' has no CiA 402 axes; remove axes"]


def test_missing_402_objects_at_the_slot_offset(tmp_path: Path) -> None:
    # one axis -> the single-axis EDS, which has nothing at 0x6840.. (the family map is not checked again)
    assert problems(tmp_path, f"""
        nodes:
          left: {{node_id: 1, axes: [{{joint: a, slot: 1, scaling: {SCALED}}}]}}
    """) == [
        'drives.yaml: nodes.left.axes[0]: none of the CiA 402 objects of axis slot 1 are in generic402.eds '
        '(0x6840 controlword (axis slot 1), 0x6841 statusword (axis slot 1), 0x6860 modes of operation '
        '(axis slot 1), 0x6861 modes of operation display (axis slot 1), 0x6864 position actual value '
        '(axis slot 1)); is it a CiA 402 device, and is the slot right?']


def test_simulation_on_socketcan_and_unknown_simulated_node(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        bus: {interface: socketcan, channel: can0}
        simulation: {enabled: true, nodes: {lefty: {}}}
        nodes:
          left: {node_id: 1, axes: []}
    """) == [
        "drives.yaml: simulation.enabled: simulated drives run only on bus.interface 'virtual', got 'socketcan'; "
        "disable the simulation or use 'virtual'",
        "drives.yaml: simulation.nodes.lefty: unknown node (did you mean 'left'?); the nodes are: left",
    ]


def test_yaml_syntax_error_names_line_and_column(tmp_path: Path) -> None:
    assert problems(tmp_path, 'nodes:\n  left: {node_id: 1\n  right: 2\n') == [
        "drives.yaml: line 3, column 8: YAML syntax error: while parsing a flow mapping expected ',' or '}', "
        "but got ':'"]


def test_missing_nodes_section(tmp_path: Path) -> None:
    assert problems(tmp_path, 'bus: {interface: virtual}\n') == [
        'drives.yaml: nodes: required key is missing; expected a mapping of node name -> node section']


def test_empty_file_and_not_a_mapping(tmp_path: Path) -> None:
    assert problems(tmp_path, '') == [
        'drives.yaml: nodes: required key is missing; expected a mapping of node name -> node section']
    assert problems(tmp_path, '- a\n- b\n') == [
        'drives.yaml: expected a mapping with the sections bus, master, options, defaults, nodes, simulation, '
        'access, record, trajectory, got a list']


def test_missing_config_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as caught:
        load_bus_config(tmp_path / 'nope.yaml')
    assert str(caught.value) == f'{tmp_path / "nope.yaml"}: file not found (looked for {tmp_path / "nope.yaml"})'


def test_node_id_in_defaults(tmp_path: Path) -> None:
    assert problems(tmp_path, 'defaults: {node_id: 3}\nnodes:\n  a: {node_id: 1, axes: []}\n') == [
        'drives.yaml: defaults.node_id: node_id must be given in each node, not in defaults']


def test_errors_from_defaults_name_the_inheriting_node(tmp_path: Path) -> None:
    assert problems(tmp_path, """
        defaults: {sdo: [{index: 0x2000, sub_index: 0, value: 1}], heartbeat_producer: -1}
        nodes:
          a: {node_id: 1, axes: []}
    """) == [
        "drives.yaml: defaults.sdo[0]: object 0x2000:00 is not in generic402.eds (inherited from defaults by node 'a')",
        "drives.yaml: defaults.heartbeat_producer: expected an integer 0..65535, got -1 (inherited from defaults "
        "by node 'a')",
    ]


def test_parse_bus_config_uses_the_given_source_name(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_bus_config({'nodes': {'a': {'node_id': 'x'}}}, '<parameter config>', tmp_path)
    assert str(caught.value) == "<parameter config>: nodes.a.node_id: expected an integer 1..127, got 'x'"
