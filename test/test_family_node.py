"""The family as a description plus a per-node part: ``get_family`` gives one object per family,
shared by the configuration and the master; what a boot learns of one node lives in that
node's FamilyNode, never on the family (two SERVOSTARs of config/servostar_example.yaml,
simulated, on one virtual bus)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from bustools import config_from, running, unique_channel
from drive_bridge.families import DriveFamily, FamilyNode, get_family, register_family, unregister_family
from drive_bridge.families.servostar import ServostarQuirks
from drive_bridge.families.servostar.node import ServostarNode

EXAMPLE = Path(__file__).resolve().parent.parent / 'config' / 'servostar_example.yaml'


def test_get_family_gives_one_object_per_family() -> None:
    assert get_family('servostar') is get_family('servostar')
    assert get_family('sinamics_s120') is not get_family('servostar')


def test_a_family_registered_again_is_a_new_object() -> None:
    class Once(DriveFamily):
        name = 'test_once'

    class Again(DriveFamily):
        name = 'test_once'

    try:
        register_family(Once)
        first = get_family('test_once')
        assert type(first) is Once and get_family('test_once') is first
        register_family(Again)
        assert type(get_family('test_once')) is Again
    finally:
        unregister_family('test_once')


def test_the_default_node_part_is_plain_cia_301_402() -> None:
    config = config_from({'bus': {'interface': 'virtual', 'channel': unique_channel('famnode')},
                          'nodes': {'arm': {'node_id': 3, 'axes': [{'joint': 'a'}]}}})
    family = get_family('generic_402')
    part = family.node(config.nodes[0])
    assert type(part) is FamilyNode and part.family is family and part.config is config.nodes[0]
    port: Any = None  # the defaults ask nothing of the node
    assert (part.boot_steps_early(port), part.boot_steps_before(port), part.boot_steps_after(port)) == ((), (), ())
    assert part.parameters(port) is None and part.stop_run_on(by_sdo=True)
    assert part.decode_emcy(bytes.fromhex('1023000000000000'), 1.0).code == 0x2310


def test_two_nodes_of_one_family_share_the_family_and_keep_their_own_parts() -> None:
    data = yaml.safe_load(EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('famnode')
    config = config_from(data)
    family = get_family('servostar')
    empty = dict(vars(family))
    with running(config, boot_timeout=15.0) as (master, _sim):
        x, y = master.nodes['axis_x'], master.nodes['axis_y']
        assert x.family is y.family is family  # the configuration's and the master's one object
        assert isinstance(x.family_node, ServostarNode) and isinstance(y.family_node, ServostarNode)
        assert x.family_node is not y.family_node
        assert x.family_node.config is x.config and y.family_node.config is y.config
        # each part holds what its own boot learned: its axis' quirks, the cycle and the drive's units
        assert set(x.family_node.drivers.values()) == {master.axes['x_joint'].quirks}
        assert set(y.family_node.drivers.values()) == {master.axes['y_joint'].quirks}
        assert all(isinstance(d, ServostarQuirks) for d in (*x.family_node.drivers.values(),
                                                          *y.family_node.drivers.values()))
        assert x.family_node.units is not None and y.family_node.units is not None
        assert x.family_node.cycle_period == y.family_node.cycle_period == config.master.cycle_period
        # and the family none: it is the same description before and after two boots
        assert dict(vars(family)) == empty == {}


def test_a_family_that_sets_a_flat_trait_is_refused_naming_its_record() -> None:
    from drive_bridge.families import FamilyError

    class Flat(DriveFamily):
        name = 'test_flat'
        has_heartbeat = False

    with pytest.raises(FamilyError, match=r'has_heartbeat: set boot = BootTraits\(has_heartbeat=\.\.\.\) instead'):
        register_family(Flat)
    with pytest.raises(FamilyError):
        get_family('test_flat')


def test_the_s120_map_of_a_config_that_gives_one_kind_follows_its_prepared_eds() -> None:
    """The family keeps no EDS between hooks: given only its TPDOs, a node of the flat S120 EDS
    (0x6060 not PDO-mappable there) gets the default RPDOs without 0x6060, as with no PDOs given."""
    from test_s120_family import FLAT, example
    if not FLAT.exists():
        pytest.skip('the vendor EDS is not in ../shared')
    data = example()
    data['defaults']['dcf'] = str(FLAT)
    whole = config_from(data).nodes[0]
    data['nodes']['arm']['tpdo'] = {p.number: {'cob_id': p.cob_id, 'transmission': p.transmission,
                                               'mapping': [{'index': e.index, 'sub_index': e.subindex}
                                                           for e in p.mapping]} for p in whole.tpdo}
    arm = config_from(data).nodes[0]
    assert [[e.index for e in p.mapping] for p in arm.rpdo] == [[e.index for e in p.mapping] for p in whole.rpdo]
    assert 0x6060 not in {e.index for p in arm.rpdo for e in p.mapping}
