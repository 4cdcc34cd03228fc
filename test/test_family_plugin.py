"""A drive family from outside the package, found through the ``drive_bridge.families``
entry point, with the three parts docs/families.md names: the description (``DriveFamily``:
its boot-up shows as an EMCY, it has no heartbeat and is supervised by node guarding, and its
EMCYs carry the axis and a severity in the manufacturer bytes), the per-node part
(``FamilyNode``: what its boot reads of one node) and the axis quirks (``AxisQuirks``: its own
name for a mode). The bridge boots, supervises, decodes and drives its simulated drive with no
change to drive_bridge.

The plugin is a module and a ``.dist-info`` written into a temporary directory put on
``sys.path``, as an installed integrator's package would be: importlib.metadata finds its
entry point like any other.
"""
from __future__ import annotations

import importlib
import sys
import textwrap
import time
from collections.abc import Iterator

import pytest

from bustools import config_from, eventually, running, unique_channel
from drive_bridge.cia301.emcy import Severity
from drive_bridge.families import discover_families, get_family, unregister_family
from drive_bridge.master.events import EventKind
from drive_bridge.sim import registry as sim_registry
from timingtools import BUSY_SLACK

FAMILY = 'acme_guarded'
NODE = 9
GUARD_MS = 50
FACTOR = 3

PLUGIN = textwrap.dedent('''
    """ACME servo drives: boot-up by EMCY 0xACB0, node guarding only, axis and severity in
    the EMCY's manufacturer bytes (byte 3 = axis slot, byte 4 = 1 warning / 2 fault); the boot
    reads each drive's device type into the node's own part; the drive calls cyclic synchronous
    velocity "acme_speed"."""
    from drive_bridge.cia301.emcy import Severity
    from drive_bridge.cia402.quirks import AxisQuirks
    from drive_bridge.families import (AxisTraits, BootDetection, BootTraits, DriveFamily, FamilyNode, Liveness,
                                       get_family)
    from drive_bridge.sim import SimDrive402, register_simulator

    BOOTUP = bytes.fromhex('b0ac000000000000')
    TEXTS = {0xFF10: 'ACME motor winding too hot', 0xFF20: 'ACME encoder signal weak'}


    class AcmeQuirks(AxisQuirks):
        def parse_mode(self, mode):
            return 9 if mode == 'acme_speed' else super().parse_mode(mode)


    class AcmeNode(FamilyNode):
        def __init__(self, family, config):
            super().__init__(family, config)
            self.device_type = None  # learned by the boot, of this node only

        def axis_quirks(self, axis):
            return AcmeQuirks()

        def boot_steps_before(self, node):
            return (('ACME device type 0x1000', self._read_device_type),)

        def _read_device_type(self, node):
            self.device_type = node.sdo_read(0x1000, 0)


    class AcmeGuarded(DriveFamily):
        name = 'acme_guarded'
        description = 'ACME servo (test plugin)'
        boot = BootTraits(detection=BootDetection.EMCY)
        axes = AxisTraits(max_count=2)

        def eds_for(self, axis_count):
            return get_family('generic_402').eds_for(axis_count)

        def default_pdos(self, node_id, axes, synchronous):
            return get_family('generic_402').default_pdos(node_id, axes, synchronous)

        def liveness(self, config):
            return Liveness.GUARDING  # the drive has no heartbeat

        def is_bootup_emcy(self, data):
            return bytes(data) == BOOTUP

        def node(self, config):
            return AcmeNode(self, config)

        def decode_emcy(self, node_id, node_name, data, timestamp):
            event = super().decode_emcy(node_id, node_name, data, timestamp)
            if event.code not in TEXTS:
                return event
            slot, level = event.manufacturer[0], event.manufacturer[1]
            return event.with_meaning(text=TEXTS[event.code], slot=slot,
                                      severity=Severity.WARNING if level == 1 else Severity.ERROR)


    @register_simulator('acme_guarded')
    class SimAcme(SimDrive402):
        def __init__(self, node, *, options=None):
            super().__init__(node, options={'heartbeat': False, **dict(options or {})})

        def announce_bootup(self):
            self.send(0x80 + self.node_id, BOOTUP)
''')

DIST_INFO_ENTRY_POINTS = f'[drive_bridge.families]\n{FAMILY} = acme_plugin:AcmeGuarded\n'


@pytest.fixture(scope='module')
def plugin(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    root = tmp_path_factory.mktemp('site')
    (root / 'acme_plugin.py').write_text(PLUGIN)
    dist = root / 'acme_plugin-1.0.dist-info'
    dist.mkdir()
    (dist / 'METADATA').write_text('Metadata-Version: 2.1\nName: acme-plugin\nVersion: 1.0\n')
    (dist / 'entry_points.txt').write_text(DIST_INFO_ENTRY_POINTS)
    sys.path.insert(0, str(root))
    importlib.invalidate_caches()
    try:
        assert FAMILY in discover_families(), 'the entry point was not found'
        yield
    finally:
        sys.path.remove(str(root))
        unregister_family(FAMILY)
        sim_registry._SIMULATORS.pop(FAMILY, None)  # type: ignore[attr-defined]
        sys.modules.pop('acme_plugin', None)


def bus(channel: str, **node: object) -> dict[str, object]:
    return {
        'bus': {'interface': 'virtual', 'channel': channel},
        'master': {'sync_period': 4000},
        'nodes': {'acme': {'node_id': NODE, 'family': FAMILY, 'guard_time_ms': GUARD_MS,
                           'life_time_factor': FACTOR, **node,
                           'axes': [{'joint': 'wrist_joint'}]}},
    }


def test_the_plugin_family_is_found_by_its_entry_point(plugin: None) -> None:
    family = get_family(FAMILY)
    assert type(family).__module__ == 'acme_plugin'


def test_boots_on_the_bootup_emcy_and_is_supervised_by_guarding(plugin: None) -> None:
    config = config_from(bus(unique_channel('acme')))
    with running(config) as (master, sim):
        node = master.nodes['acme']
        drive = sim.drive(NODE)
        assert node.snapshot().liveness == 'node guarding'
        assert node.family is get_family(FAMILY) and type(node.family_node).__name__ == 'AcmeNode'
        assert node.family_node.device_type == drive.value(0x1000)  # type: ignore[attr-defined]
        assert not master.events or all(e.kind is not EventKind.BOOT_FAILED for e in master.events)
        assert drive.value(0x100C) == GUARD_MS and drive.value(0x100D) == FACTOR
        replies, started = drive.guard_replies, time.monotonic()
        time.sleep(0.5)
        # one RTR every guard time: about 10 in 0.5 s; never more often, fewer on a busy machine
        answered = drive.guard_replies - replies
        assert 2 <= answered <= (time.monotonic() - started) * 1000 / GUARD_MS + 4, answered
        axis = master.axes['wrist_joint']
        axis.enable(timeout=2.0)
        assert axis.feedback()[0]


def test_the_axis_takes_the_family_s_own_mode_name_through_its_quirks(plugin: None) -> None:
    config = config_from(bus(unique_channel('acme')))
    with running(config) as (master, sim):
        axis = master.axes['wrist_joint']
        assert type(axis.quirks).__name__ == 'AcmeQuirks'  # type: ignore[attr-defined]
        axis.set_mode('acme_speed', timeout=2.0 + BUSY_SLACK)
        assert sim.drive(NODE).value(0x6061) == 9  # cyclic synchronous velocity, on the drive
        with pytest.raises(Exception, match='acme_fast'):  # any other name is the profile's to refuse
            axis.set_mode('acme_fast')


def test_emcy_decoded_by_the_family_with_axis_and_severity(plugin: None) -> None:
    config = config_from(bus(unique_channel('acme')))
    seen = []
    with running(config) as (master, sim):
        master.add_emcy_listener(seen.append)
        sim.drive(NODE).emcy.error(0xFF20, manufacturer=bytes([0, 1, 0, 0, 0]), transient=True)
        eventually(lambda: any(e.code == 0xFF20 for e in seen), 1.0, 'the EMCY')
        event = next(e for e in seen if e.code == 0xFF20)
        assert event.text == 'ACME encoder signal weak'
        assert event.severity is Severity.WARNING and event.slot == 0 and not event.is_reset
        assert master.axes['wrist_joint'].last_emcy() is not None


def test_a_silent_node_is_lost_and_configured_again_when_it_answers(plugin: None) -> None:
    config = config_from(bus(unique_channel('acme')))
    with running(config) as (master, sim):
        drive = sim.drive(NODE)
        axis = master.axes['wrist_joint']
        axis.enable(timeout=2.0)
        drive.stop_guarding_replies(True)
        silent = time.monotonic()
        eventually(lambda: not master.nodes['acme'].available, 2.0, 'node lost')
        elapsed = time.monotonic() - silent
        # life time 150 ms, plus the supervisor's 20 ms poll and scheduling on a busy machine
        assert elapsed < GUARD_MS * FACTOR / 1000 + BUSY_SLACK
        assert not axis.feedback()[0]
        lost = [e for e in master.events if e.kind is EventKind.GUARDING_LOST]
        assert lost and f'node {NODE}' in lost[-1].message and 'acme' in lost[-1].message
        drive.stop_guarding_replies(False)
        eventually(lambda: master.nodes['acme'].available, 5.0, 'configured again')
        assert any(e.kind is EventKind.GUARDING_BACK for e in master.events)
        # the drive kept its state through the loss: the bridge disables it at once, and never
        # re-enables it by itself
        eventually(lambda: axis.drive_state.label == 'ready', 1.0, 'disabled after the node came back')
        time.sleep(0.3)
        assert axis.drive_state.label == 'ready'


def test_a_family_names_a_vendor_from_the_cia_register_when_its_eds_files_do_not() -> None:
    from drive_bridge.cia301.vendors import VENDOR_NAMES
    from drive_bridge.families import get_family
    generic = get_family('generic_301')  # ships no EDS of any maker
    assert generic.vendor_name(0x9A) == VENDOR_NAMES[0x9A]
    assert generic.vendor_name(0x12345) is None
