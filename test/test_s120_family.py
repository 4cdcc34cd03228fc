"""The SINAMICS S120 family at core level: the loader with the real Siemens EDS files, the family
hooks, and the master against the simulated S120 (SimS120) on a virtual bus, every frame recorded
(akdtools.Sniffer). No ROS here (test_s120_ros.py does the same through ROS).

The shipped example (config/s120_example.yaml): node 5 with two drive objects (p8743 = [3, 4]),
node 7 with one (DO 2), SYNC 8 ms, the simulator's p8848 = 4 ms, 2048 pulses x 2^11 increments
per revolution, r0333 = 10 N·m. Timing bounds are generous: CI is a noisy 2-core machine.
"""
from __future__ import annotations

import dataclasses
import logging
import math
import struct
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import can
import pytest
import yaml

from akdtools import Sniffer
from bustools import config_from, eventually, running, unique_channel
from drive_bridge.cia301.emcy import Severity
from drive_bridge.cia402.axis import Axis
from drive_bridge.cia402.errors import AxisError
from drive_bridge.cia402.statemachine import State
from drive_bridge.config import ConfigError
from drive_bridge.families import Liveness, get_family
from drive_bridge.families.errors import ParameterError
from drive_bridge.families.s120 import S120Quirks, SinamicsS120, boot as s120_boot, emcy as s120_emcy, pdos as s120_pdos
from drive_bridge.families.s120.errors import S120BootError
from drive_bridge.families.s120.parameters import parse_name
from drive_bridge.master.master import Master
from drive_bridge.model import AxisConfig, BusConfig, PdoConfig, PdoEntry
from drive_bridge.sim import SimulatedBus
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint
from timingtools import assert_follows

REPO = Path(__file__).resolve().parent.parent
EXAMPLE = REPO / 'config' / 's120_example.yaml'
EDS_DIR = REPO.parent / 'shared' / 'realdata' / 'eds'
MODULAR = EDS_DIR / 'SINAMICS_S120_V48__SINAMICS_S120.eds'
FLAT = EDS_DIR / 'sinamics_s120.eds'
ARM, WRIST = 5, 7
SDO_RX = 0x600 + ARM
INC_PER_REV = 2048 << 11
RAD_PER_INC = 2 * math.pi / INC_PER_REV
SYNC = 0x080

needs_eds = pytest.mark.skipif(not MODULAR.exists() or not FLAT.exists(),
                               reason='the Siemens EDS files are in ../shared/realdata/eds beside the repository')
pytestmark = needs_eds


def example(arm: dict[str, Any] | None = None, wrist: dict[str, Any] | None = None, **master: Any) -> dict[str, Any]:
    """The shipped example as data, on a channel of its own, with absolute EDS paths, simulator
    options of the two nodes updated and master keys replaced."""
    data = yaml.safe_load(EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('s120')
    data['defaults']['dcf'] = str(MODULAR)
    data['master'].update(master)
    data['simulation']['nodes']['arm'].update(arm or {})
    data['simulation']['nodes']['wrist'].update(wrist or {})
    return data


def problems(data: dict[str, Any]) -> list[str]:
    with pytest.raises(ConfigError) as caught:
        config_from(data, 's120.yaml')
    return str(caught.value).splitlines()


@contextmanager
def bridge(data: dict[str, Any], wait: bool = True) -> Iterator[tuple[Master, SimulatedBus, Sniffer]]:
    config: BusConfig = config_from(data)
    sniffer = Sniffer(config.bus.channel)  # type: ignore[arg-type]
    try:
        with running(config, boot_timeout=15.0, wait=wait) as (master, sim):
            yield master, sim, sniffer
    finally:
        sniffer.close()


def sdo_requests(sniffer: Sniffer, node: int = ARM, after: int = 0) -> list[tuple[int, int, int, bytes]]:
    """(command byte, index, subindex, data) of every SDO request (initiate) to the node."""
    found = []
    for frame in sniffer.frames(0x600 + node, after):
        if frame.data and frame.data[0] & 0xE0 in (0x20, 0x40):
            index, sub = struct.unpack_from('<HB', frame.data, 1)
            found.append((frame.data[0], index, sub, frame.data[4:]))
    return found


def enabled(master: Master, joint: str) -> Axis:
    axis = master.axes[joint]
    assert isinstance(axis, Axis) and isinstance(axis.quirks, S120Quirks)
    axis.enable(timeout=3.0)
    assert axis.snapshot().state is State.OPERATION_ENABLED
    return axis


# -- configuration ----------------------------------------------------------------------------------
def test_the_example_loads_with_the_family_defaults() -> None:
    config = config_from(example())
    arm, wrist = config.nodes
    assert arm.family == wrist.family == 'sinamics_s120' and arm.eds_path == MODULAR
    assert (arm.guard_time_ms, arm.life_time_factor, arm.heartbeat_producer_ms) == (100, 3, 0)
    assert config.master.sync_period == 0.008
    shoulder, elbow = arm.axes
    assert (shoulder.mode, shoulder.position_mode, shoulder.velocity_mode, shoulder.effort_mode) == (3, 3, 3, 4)
    assert shoulder.position_loop.enabled and shoulder.position_loop == SinamicsS120.modes.default_position_loop
    assert elbow.drive == {'gear_ratio': 10.0, 'direction': -1} and elbow.slot == 1
    # the default map: two PDOs each way per drive object, type 1, COB-IDs of node 5 only
    assert [(p.number, p.cob_id, p.transmission) for p in arm.rpdo] == [
        (1, 0x205, 1), (2, 0x305, 1), (65, 0x405, 1), (66, 0x505, 1)]
    assert [(p.number, p.cob_id) for p in arm.tpdo] == [(1, 0x185), (2, 0x285), (65, 0x385), (66, 0x485)]
    assert [(e.index, e.bits) for e in arm.rpdo[2].mapping] == [(0x6840, 16), (0x6860, 8), (0x6871, 16),
                                                               (0x6842, 16)]
    assert [(e.index, e.bits) for e in arm.rpdo[3].mapping] == [(0x68FF, 32)]
    assert [(e.index, e.bits) for e in arm.tpdo[2].mapping] == [(0x6841, 16), (0x6861, 8), (0x6877, 16)]
    assert [(e.index, e.bits) for e in arm.tpdo[3].mapping] == [(0x6863, 32), (0x686C, 32)]
    assert [(p.number, p.cob_id) for p in wrist.rpdo] == [(1, 0x207), (2, 0x307)]
    family = get_family('sinamics_s120')
    assert family.liveness(arm) is Liveness.GUARDING
    assert family.axis_objects(1).position_actual == (0x6863, 0)
    assert not config.warnings


@pytest.mark.parametrize('eds', [MODULAR, FLAT], ids=['modular V4.8', 'flat'])
def test_both_real_siemens_eds_files_load_for_a_two_axis_node(eds: Path) -> None:
    data = example()
    data['defaults']['dcf'] = str(eds)
    arm = config_from(data).nodes[0]
    od = arm.od
    for slot in (0, 1):  # every object the bridge uses, at the slot's offsets
        for index in (0x6040, 0x6041, 0x6061, 0x6063, 0x606C, 0x6071, 0x60FF, 0x6007, 0x6094):
            assert index + 0x800 * slot in od, hex(index + 0x800 * slot)
        for base in (0x1400, 0x1600, 0x1800, 0x1A00):
            assert all(base + 0x40 * slot + k in od for k in range(8))
            assert base + 0x40 * slot + 8 not in od  # 8 PDOs per drive object
        assert 0x6064 + 0x800 * slot not in od  # the S120 has no 0x6064
    assert len(od[0x1640].subindices) == 5  # count + 4 entries
    if eds == FLAT:  # taken as it is: 0x6060 not mappable, no 0x6077 -> left out of the map (0x6060 by SDO)
        assert [e.index for e in arm.rpdo[0].mapping] == [0x6040, 0x6071]
        assert [e.index for e in arm.tpdo[0].mapping] == [0x6041, 0x6061]
    else:
        assert od[0x6860].pdo_mappable and od[0x1840][1].default == 0xC00006DF  # as the V4.8 module M2
        assert od[0x1800][1].default == 0x40000185 and od[0x1641][2].default == 0x68FF0020


def test_a_fragment_that_is_not_the_node_eds_is_refused() -> None:
    data = example()
    data['defaults']['dcf'] = str(EDS_DIR / 'SINAMICS_S120_V48__SINAMICS_SERVO.eds')
    found = problems(data)
    assert any('describes no drive object' in p and 'SINAMICS_S120.eds' in p for p in found), found


def test_guarding_is_required_and_axis_settings_are_checked() -> None:
    data = example()
    data['defaults'].pop('guard_time_ms')
    data['defaults'].pop('life_time_factor')
    assert any("family 'sinamics_s120' is supervised by node guarding" in p and 'guard_time_ms' in p
               for p in problems(data))
    data = example()
    arm = data['nodes']['arm']
    arm['axes'][0]['scaling'] = {'counts_per_revolution': 1000}
    arm['axes'][1]['drive'] = {'gear_ratio': -2, 'direction': 2, 'encoder': 'yes', 'gear': 1}
    arm['axes'][1]['mode'] = 'csp'
    found = problems(data)
    for expected in ("scales from the axis' `drive` settings; remove scaling",
                     'drive.gear_ratio: expected a number > 0, got -2', 'drive.direction: expected 1 or -1',
                     "drive.encoder: expected true or false, got 'yes'", 'drive.gear: unknown key',
                     "family 'sinamics_s120' does not accept mode csp"):
        assert any(expected in p for p in found), (expected, found)


def test_default_cob_ids_are_deterministic_clash_free_and_within_the_drive_range() -> None:
    seen: dict[int, tuple[int, int]] = {}
    for node_id in range(1, 128):
        for slot in (0, 1):
            (rx_a, rx_b), (tx_a, tx_b) = s120_pdos.cob_ids(node_id, slot)
            for cob in (rx_a, rx_b, tx_a, tx_b):
                assert cob not in seen, (node_id, slot, hex(cob), seen[cob])
                assert cob & 0x7F == node_id and 0x181 <= cob <= 0x57F <= 0x6DF  # its own predefined set
                seen[cob] = (node_id, slot)
    assert s120_pdos.cob_ids(5, 2) == ((0x206, 0x306), (0x186, 0x286))  # slots 2, 3: node id + 1's set
    with pytest.raises(ValueError, match='node id 128'):
        s120_pdos.cob_ids(127, 2)
    # slots 2 and 3 take node id 6's set: a node 6 on the bus is a clash the loader names
    data = example()
    data['nodes']['arm']['axes'] += [{'joint': 'j2', 'slot': 2}, {'joint': 'j3', 'slot': 3}]
    data['nodes']['wrist']['node_id'] = 6
    data['simulation'] = {'enabled': False}
    assert any('COB-ID 0x186 is already used' in p for p in problems(data))


def test_pdo_limits_are_named() -> None:
    def pdo(number: int, entries: int = 1, cob: int = 0x205, enabled: bool = True) -> PdoConfig:
        return PdoConfig(number, cob, enabled, mapping=tuple(PdoEntry(0x6040, 0, 16) for _ in range(entries)))
    found = s120_pdos.check_pdos([pdo(9), pdo(65, 5), pdo(66, cob=0x6E5)], [pdo(200)], [0, 1])
    assert any('RPDO 9: a drive object has at most 8 RPDOs, numbered 64 x slot + 1..8' in p for p in found), found
    assert any('RPDO 65 (PDO 1 of the drive object in slot 1): 5 objects mapped; an S120 PDO carries at most 4' in p
               for p in found), found
    assert any('COB-ID 0x6E5 is above the highest the drive takes (0x6DF)' in p for p in found), found
    assert any('TPDO 200' in p and 'no axis of the node is in slot 3' in p for p in found), found
    many = [pdo(64 * slot + k + 1, cob=0x200 + 8 * slot + k) for slot in range(4) for k in range(7)]
    assert s120_pdos.check_pdos(many, []) == [
        '28 valid RPDOs; one S120 Control Unit receives at most 25 valid RPDOs over all its drive objects '
        '(alarm A08758): disable some or shrink the map']
    assert not s120_pdos.check_pdos(many[:25] + [pdo(n, enabled=False) for n in (8, 72, 136)], [])
    # an axis with more than 4 objects in a PDO is refused by the loader (the EDS has 4 entries)
    data = example()
    data['nodes']['wrist']['rpdo'] = {1: {'mapping': [{'index': 0x6040, 'sub_index': 0}] * 5}}
    assert any('5 objects mapped, but 0x1600' in p and 'room for 4' in p for p in problems(data))


def test_emcy_fault_number_and_drive_object_without_a_bus() -> None:
    slots = {4: 0, 3: 1}  # p8743 = [4, 3]
    frame = struct.pack('<HBHBxx', 0x1000, 0x81, 7900, 3)
    event = s120_emcy.decode(ARM, 'arm', frame, 1.0, slots)
    assert event.slot == 1 and event.severity is Severity.ERROR and not event.is_reset
    assert event.text.startswith('F07900 motor blocked (DO 3, axis slot 1; EMCY 0x1000')
    loss = s120_emcy.decode(ARM, 'arm', struct.pack('<HBHBxx', 0x8110, 0x11, 8751, 4), 1.0, slots)
    assert loss.slot == 0 and loss.severity is Severity.WARNING and loss.text.startswith('A08751 CBC: telegram loss')
    guard = s120_emcy.decode(ARM, 'arm', struct.pack('<HBHBxx', 0x8130, 0x11, 8700, 3), 1.0, slots)
    assert guard.severity is Severity.ERROR and guard.text.startswith('F08700 CBC: communication error')
    for number, name in ((8752, 'A08752'), (8754, 'A08754'), (8755, 'A08755'), (8757, 'A08757'), (8758, 'A08758')):
        event = s120_emcy.decode(ARM, 'arm', struct.pack('<HBHBxx', 0x1001, 0x11, number, 1), 1.0, slots)
        assert event.text.startswith(name) and event.slot is None and 'no axis of this node' in event.text
        assert event.severity is Severity.WARNING
    cu = s120_emcy.decode(ARM, 'arm', struct.pack('<HBHBxx', 0x1000, 0x81, 30001, 1), 1.0, slots)
    assert cu.slot is None and cu.text.startswith('F30001 power unit: overcurrent')
    reset = s120_emcy.decode(ARM, 'arm', bytes(8), 1.0, slots)
    assert reset.is_reset and reset.severity is Severity.INFO
    unknown = s120_emcy.decode(ARM, 'arm', struct.pack('<HBHBxx', 0x1000, 0x81, 12345, 3), 1.0, {})
    assert 'F12345' in unknown.text and 'p8743 not read yet' in unknown.text and unknown.slot is None


def test_parameter_names() -> None:
    assert parse_name('p2000').address == (0, 0, 0x27D0, 0)  # type: ignore[union-attr]
    assert parse_name('r0062').label == 'r0062'  # type: ignore[union-attr]
    assert parse_name(' P1120[0] ').address == (0, 0, 0x2460, 0)  # type: ignore[union-attr]
    assert parse_name('p8743.1').address == (0, 0, 0x4227, 1)  # type: ignore[union-attr]
    assert parse_name('p12345[300]').address == (1, 1, 0x2000 + 2345, 44)  # type: ignore[union-attr]
    for bad in ('2000', 'x2000', 'p', 'DRV.ACC', 'p20000000'):
        assert parse_name(bad) is None, bad


# -- boot -------------------------------------------------------------------------------------------
def test_a_node_that_starts_stopped_gets_nmt_pre_operational_before_its_first_sdo() -> None:
    with bridge(example(arm={'p8684': 4})) as (master, sim, sniffer):
        assert master.nodes['arm'].available
        frames = sniffer.frames()
        first_sdo = next(i for i, f in enumerate(frames) if f.cob_id == SDO_RX)
        nmt = [f.data for f in frames[:first_sdo] if f.cob_id == 0x000]
        assert bytes([0x80, ARM]) in nmt, [n.hex(' ') for n in nmt]  # 000 [80 05] before the first SDO
        # after the reset communication that left it stopped
        assert nmt.index(bytes([0x82, ARM])) < nmt.index(bytes([0x80, ARM]))
        assert sim.drive(ARM).nmt_state == 'OPERATIONAL'


def test_a_two_do_node_gets_cob_ids_for_its_second_axis_and_both_joints_move() -> None:
    with bridge(example(arm={'mapping_sub0_read_only': True})) as (master, sim, sniffer):
        drive = sim.drive(ARM)
        # slot 1 (PDO 65/66) on node 5's predefined set; slot 0's default PDO 3/4 freed first
        assert [drive.value(0x1440 + k, 1) for k in (0, 1)] == [0x405, 0x505]
        assert [drive.value(0x1840 + k, 1) & 0x7FF for k in (0, 1)] == [0x385, 0x485]
        assert all(drive.value(i, 1) & 0x80000000 for i in (0x1402, 0x1403, 0x1802, 0x1803, 0x1442, 0x1842))
        assert drive.value(0x1641, 0) == 1 and drive.value(0x1641, 1) == 0x68FF0020  # sub0 read-only: by entries
        shoulder, elbow = enabled(master, 'shoulder_joint'), enabled(master, 'elbow_joint')
        shoulder.command(velocity=0.5)
        elbow.command(velocity=0.25)
        eventually(lambda: abs(shoulder.feedback()[2] - 0.5) < 0.01 and abs(elbow.feedback()[2] - 0.25) < 0.01,
                   5.0, 'both joints at their velocity')
        # gear 10, 4194304 inc/rev: 0.5 rad/s = 3337722 inc/s at the motor; elbow's direction -1
        assert drive.view(3).setpoint == pytest.approx(0.5 * 10 / RAD_PER_INC, abs=1)
        assert drive.view(4).setpoint == pytest.approx(-0.25 * 10 / RAD_PER_INC, abs=1)
        for joint in ('shoulder_joint', 'elbow_joint'):
            stamps = [master.axes[joint].feedback()[4]]
            time.sleep(0.1)
            assert master.axes[joint].feedback()[4] > stamps[0]  # TPDOs keep coming
        assert sniffer.frames(0x385) and sniffer.frames(0x485) and sniffer.frames(0x405)


def test_a_cycle_shorter_than_twice_p8848_is_refused_naming_p8848() -> None:
    with bridge(example(sync_period=4000), wait=False) as (master, _sim, _sniffer):
        arm = master.nodes['arm']
        eventually(lambda: arm.boot_error, 10.0, 'the boot error')
        assert not arm.available
        error = arm.boot_error
        assert 'CAN sampling time p8848' in error and '2 x p8848 = 8 ms' in error, error
        assert 'master.sync_period to at least 8000 us' in error and 'p8848 on the drive to at most 2 ms' in error


def test_guarding_is_configured_and_a_lost_bridge_stops_the_drive_per_p8641(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING, 'drive_bridge.families.s120')
    with bridge(example(arm={'p8641': [3, 0]})) as (master, sim, _sniffer):
        drive = sim.drive(ARM)
        assert (drive.value(0x100C), drive.value(0x100D), drive.value(0x1017)) == (100, 3, 0)
        assert any('DO 4 (slot 1): p8641 = 0' in r.getMessage() and 'runs on' in r.getMessage()
                   for r in caplog.records), [r.getMessage() for r in caplog.records]
        shoulder, elbow = enabled(master, 'shoulder_joint'), enabled(master, 'elbow_joint')
        shoulder.command(velocity=0.3)
        elbow.command(velocity=0.3)
        eventually(lambda: abs(drive.view(4).speed_rpm) > 20, 3.0, 'both turning')
        master.nodes['arm'].guard_active = False  # the bridge is gone: no more guarding RTRs
        # life time 300 ms: F08700 on every DO; p8641 = 3 -> OFF3 then Fault, p8641 = 0 -> an alarm only
        eventually(lambda: drive.view(3).state == 'FAULT', 3.0, 'DO 3 (p8641 = 3) in Fault')
        assert 8700 in drive.view(3).faults and abs(drive.view(3).speed_rpm) < 1
        assert 8700 in drive.view(4).alarms and drive.view(4).state == 'OPERATION_ENABLED'
        assert abs(drive.view(4).speed_rpm) > 20  # a lost bridge stops nothing where p8641 = 0


# -- process data and modes -------------------------------------------------------------------------
def test_a_type_1_rpdo_after_sync_k_takes_effect_at_sync_k_plus_1() -> None:
    data = example(sync_producer='external')
    channel = data['bus']['channel']
    bus = can.Bus(interface='virtual', channel=channel, receive_own_messages=False)
    ticking = threading.Event()
    ticking.set()
    stop = threading.Event()

    def syncs() -> None:
        while not stop.is_set():
            if ticking.is_set():
                bus.send(can.Message(arbitration_id=SYNC, data=b'', is_extended_id=False))
            time.sleep(0.008)
    producer = threading.Thread(target=syncs, daemon=True)
    producer.start()
    try:
        with bridge(data) as (master, sim, sniffer):
            drive = sim.drive(WRIST)
            axis = enabled(master, 'wrist_joint')
            ticking.clear()
            time.sleep(0.1)
            assert drive.view(2).setpoint == 0
            axis.command(velocity=0.2)  # 0x60FF = 0.2 rad/s / RAD_PER_INC = 133509 inc/s
            wanted = round(0.2 / RAD_PER_INC)
            mark = sniffer.mark
            bus.send(can.Message(arbitration_id=SYNC, data=b'', is_extended_id=False))  # SYNC k
            rpdo = sniffer.wait(0x307, mark, data=struct.pack('<i', wanted), timeout=2.0)[0]
            assert [f.cob_id for f in sniffer.frames(SYNC, mark)] and rpdo.index > sniffer.frames(SYNC, mark)[0].index
            time.sleep(0.2)
            assert drive.view(2).setpoint == 0, 'applied before the next SYNC'
            bus.send(can.Message(arbitration_id=SYNC, data=b'', is_extended_id=False))  # SYNC k + 1
            eventually(lambda: drive.view(2).setpoint == wanted, 1.0, 'the setpoint at SYNC k + 1')
            ticking.set()
    finally:
        stop.set()
        producer.join(timeout=2)
        bus.shutdown()


def test_set_mode_waits_for_0x6061_and_position_modes_are_refused_without_an_sdo() -> None:
    with bridge(example()) as (master, sim, sniffer):
        drive = sim.drive(ARM)
        elbow = master.axes['elbow_joint']
        elbow.set_mode('pt')
        assert elbow.snapshot().mode == 4 and drive.view(4).mode == 4
        mark = sniffer.mark
        for mode in ('csp', 'ip', 'hm'):
            with pytest.raises(AxisError, match=f"mode {mode} is not accepted by this drive family"):
                elbow.set_mode(mode)
        time.sleep(0.1)
        assert not [r for r in sdo_requests(sniffer, ARM, mark) if r[1] in (0x6060, 0x6860)]
        assert {f.data[2] for f in sniffer.frames(0x405, mark)} == {4}  # 0x6860 in RPDO 65 stays pt
        assert drive.view(4).requested_mode == 4
        elbow.set_mode('pv')
        eventually(lambda: drive.view(4).mode == 3, 1.0, 'back in pv')


def test_velocity_mode_takes_its_setpoint_in_rpm_from_0x6042() -> None:
    with bridge(example()) as (master, sim, sniffer):
        drive = sim.drive(WRIST)
        axis = master.axes['wrist_joint']
        axis.set_mode('vl')
        assert drive.view(2).mode == 2
        enabled(master, 'wrist_joint')
        axis.command(velocity=30 * 2 * math.pi / 60)  # 30 rpm (gear 1)
        eventually(lambda: drive.view(2).setpoint == 30, 2.0, '0x6042 = 30 rpm')
        frame = sniffer.frames(0x207)[-1]
        assert struct.unpack('<HbhH', frame.data)[1:] == (2, 0, 30)  # RPDO 1: cw, mode vl, 0x6071, 0x6042
        eventually(lambda: abs(drive.view(2).speed_rpm - 30) < 0.5, 3.0, 'the motor at 30 rpm')
        assert axis.feedback()[2] == pytest.approx(math.pi, abs=0.02)
        axis.set_mode('pv')
        eventually(lambda: struct.unpack('<HbhH', sniffer.frames(0x207)[-1].data)[1:] == (3, 0, 0), 2.0,
                   '0x6042 = 0 out of vl')


def test_units_come_from_the_drive_object() -> None:
    # the wrist without an encoder (rpm, r1300 = 20), the arm with 1024 pulses x 2^12 and r0333 = 4 N·m
    data = example(wrist={'encoder': False},
                   arm={'encoder_pulses': 1024, 'fine_resolution': 12, 'rated_torque': [4.0, 4.0]})
    with bridge(data) as (master, sim, _sniffer):
        wrist, shoulder = master.axes['wrist_joint'], master.axes['shoulder_joint']
        assert isinstance(wrist, Axis) and isinstance(shoulder, Axis)
        assert isinstance(wrist.quirks, S120Quirks) and isinstance(shoulder.quirks, S120Quirks)
        assert wrist.quirks.units is not None and not wrist.quirks.units.has_encoder
        assert wrist.config.scaling.velocity_factor == pytest.approx(2 * math.pi / 60)  # rad/s per rpm
        assert shoulder.quirks.units is not None and shoulder.quirks.units.increments_per_revolution == 1024 << 12
        assert shoulder.config.scaling.position_factor == pytest.approx(2 * math.pi / (1024 << 12) / 10)
        assert shoulder.config.scaling.effort_factor == pytest.approx(4.0 / 1000 * 10)  # per mille of r0333, gear
        assert shoulder.quirks.drive_object == 3 and wrist.quirks.drive_object == 2
        enabled(master, 'wrist_joint')
        wrist.command(velocity=math.pi)  # 30 rpm
        eventually(lambda: sim.drive(WRIST).view(2).setpoint == 30, 2.0, '0x60FF = 30 rpm')
        with pytest.raises(AxisError, match='no encoder'):
            wrist.check_trajectory(True, False)
        shoulder.set_mode('pt')
        enabled(master, 'shoulder_joint')
        shoulder.command(effort=2.0)  # 2 N·m at the joint = 0.2 N·m at the motor = 50 per mille of 4 N·m
        eventually(lambda: sim.drive(ARM).view(3).setpoint == 50, 2.0, '0x6071 = 50 per mille')


def test_a_quintic_trajectory_on_a_pv_joint_through_the_bridges_loop() -> None:
    with bridge(example()) as (master, sim, _sniffer):
        drive = sim.drive(WRIST)
        axis = enabled(master, 'wrist_joint')
        assert axis.stream_strategy() == 'position-loop'
        executor = TrajectoryExecutor(master.axes, cycle_period=master.config.master.cycle_period)
        errors: list[float] = []

        def watch(_cycle: int) -> None:
            executor.check()
            desired = executor.desired('wrist_joint', executor.now())
            if desired is not None and executor.active():
                errors.append(abs(desired.position - drive.view(2).position * RAD_PER_INC))  # against 0x6063
        master.add_cycle_listener(watch)
        start = axis.snapshot().position
        trajectory = Trajectory(('wrist_joint',), (TrajectoryPoint(1.5, (start + 1.0,), (0.0,), (0.0,)),))
        handle = executor.submit(trajectory)  # 1 rad in 1.5 s, quintic
        assert handle is not None and handle.wait(6.0)
        assert handle.state == 'succeeded', handle.reason
        assert_follows(errors, 0.05)
        eventually(lambda: drive.view(2).setpoint == 0, 3.0, '0x60FF = 0 at rest')
        held = drive.view(2).position * RAD_PER_INC
        assert held == pytest.approx(start + 1.0, abs=5e-3)
        time.sleep(0.5)
        assert drive.view(2).position * RAD_PER_INC == pytest.approx(held, abs=1e-3)  # held
        assert drive.view(2).mode == 3 and axis.snapshot().state is State.OPERATION_ENABLED


def test_a_stalled_position_stream_marks_the_joint_stale_and_holds() -> None:
    with bridge(example()) as (master, sim, _sniffer):
        drive = sim.drive(WRIST)
        axis = enabled(master, 'wrist_joint')
        start = axis.snapshot().position
        for k in range(40):  # a stream of position commands through the loop, then silence
            axis.command(position=start + 0.01 * k)
            time.sleep(0.01)
        last = start + 0.39
        eventually(lambda: axis.snapshot().command_stale, 3.0, 'the joint stale')
        assert 'no command for 500 ms' in axis.snapshot().message
        eventually(lambda: abs(drive.view(2).speed_rpm) < 0.5, 3.0, 'at rest')
        assert axis.snapshot().position == pytest.approx(last, abs=0.01)
        time.sleep(0.5)
        assert axis.snapshot().position == pytest.approx(last, abs=0.01)
        assert axis.snapshot().state is State.OPERATION_ENABLED


# -- EMCY, faults, alarms ---------------------------------------------------------------------------
def test_an_emcy_reaches_its_joint_by_p8743_not_by_list_order() -> None:
    data = example(arm={'do_numbers': [4, 3], 'p8848': 3.0})  # 8 ms > 2 x 3 ms: no A08751 EMCY
    data['nodes']['arm']['axes'].reverse()  # the config lists slot 1 (elbow) first
    with bridge(data) as (master, sim, sniffer):
        drive = sim.drive(ARM)
        shoulder, elbow = enabled(master, 'shoulder_joint'), enabled(master, 'elbow_joint')
        mark = sniffer.mark
        drive.inject_fault(7900, 3)  # F07900 on DO 3 = p8743[1]: the elbow (slot 1)
        frame = sniffer.wait(0x80 + ARM, mark)[0]
        assert frame.data[3:6] == struct.pack('<HB', 7900, 3)
        eventually(lambda: elbow.snapshot().state is State.FAULT, 3.0, 'elbow in Fault')
        event = elbow.snapshot().last_emcy
        assert event is not None and event.slot == 1 and event.text.startswith('F07900 motor blocked (DO 3')
        assert shoulder.snapshot().last_emcy is None and shoulder.snapshot().state is State.OPERATION_ENABLED
        # acknowledged by 0x1003:00 = 0 and the controlword edge
        mark = sniffer.mark
        elbow.reset_fault(timeout=2.0)
        assert elbow.snapshot().state is not State.FAULT
        assert (0x2F, 0x1003, 0, b'\x00\x00\x00\x00') in sdo_requests(sniffer, ARM, mark)
        assert elbow.snapshot().last_emcy is None and drive.view(3).faults == ()


def test_an_alarm_outside_the_can_range_is_a_warning_without_emcy() -> None:
    with bridge(example(wrist={'p8848': 3.0})) as (master, sim, sniffer):  # 8 ms > 2 x 3 ms: no A08751
        drive = sim.drive(WRIST)
        axis = enabled(master, 'wrist_joint')
        time.sleep(0.2)
        assert not axis.snapshot().warning
        mark = sniffer.mark
        drive.inject_alarm(7910, 2)  # A07910 motor overtemperature: no EMCY, statusword bit 7
        eventually(lambda: axis.snapshot().warning, 2.0, 'the warning bit')
        time.sleep(0.2)
        assert not sniffer.frames(0x80 + WRIST, mark), 'an EMCY for an alarm outside the CAN range'
        assert axis.snapshot().state is State.OPERATION_ENABLED and axis.snapshot().last_emcy is None
        drive.clear_cause(7910)
        eventually(lambda: not axis.snapshot().warning, 2.0, 'the warning gone')


# -- parameters -------------------------------------------------------------------------------------
def test_parameters_of_two_drive_objects_read_concurrently_each_get_their_own() -> None:
    with bridge(example(arm={'max_speed': [3000.0, 1500.0]})) as (master, sim, sniffer):
        access = master.parameter_access(ARM)
        results: dict[int, set[float | None]] = {3: set(), 4: set()}
        failures: list[BaseException] = []

        def reader(do: int) -> None:
            try:
                for _ in range(15):
                    results[do].add(access.read('p1082', do).value)
            except BaseException as exc:  # reported below
                failures.append(exc)
        threads = [threading.Thread(target=reader, args=(do,)) for do in (3, 4)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(timeout=30)
        assert not failures, failures
        assert results == {3: {3000.0}, 4: {1500.0}}
        value = access.read('p1082', 0)  # 0: the first axis' DO (3)
        assert (value.value, value.unit, value.access, value.save_needed) == (3000.0, 'rpm', 'rw', True)
        assert access.read('p8743[1]', 1).value == 4  # on the Control Unit
        mark = sniffer.mark
        written = access.write('p1121', '2.5', 4)
        assert written.value == 2.5 and sim.drive(ARM).parameter(4, 1121) == 2.5
        assert (0x2B, 0x41B6, 0, b'\x04\x00\x00\x00') in sdo_requests(sniffer, ARM, mark)  # p8630[0] = DO 4
        with pytest.raises(ParameterError, match='r0333: is a display parameter'):
            access.write('r0333', '5', 3)
        with pytest.raises(ParameterError, match="a SINAMICS parameter is p or r"):
            access.read('DRV.ACC')
        with pytest.raises(ParameterError, match='reading DO 3'):
            access.read('p9999', 3)
        assert 'stored on the memory card' in access.save()
        assert sim.drive(ARM).saved_parameter(4, 1121) == 2.5


def test_more_than_25_valid_rpdos_are_refused_naming_the_limit() -> None:
    data = example()
    arm = data['nodes']['arm']
    arm['axes'] += [{'joint': 'j2', 'slot': 2}, {'joint': 'j3', 'slot': 3}]
    data['simulation'] = {'enabled': True}
    data['nodes'].pop('wrist')
    arm['rpdo'] = {64 * slot + k + 1: {'cob_id': 0x200 + 8 * slot + k + 1,
                                       'mapping': [{'index': 0x6040 + 0x800 * slot, 'sub_index': 0}]}
                   for slot in range(4) for k in range(7)}
    arm['tpdo'] = {64 * slot + 1: {'cob_id': 0x180 + slot + 1, 'mapping': [
        {'index': 0x6041 + 0x800 * slot, 'sub_index': 0}, {'index': 0x6061 + 0x800 * slot, 'sub_index': 0}]}
        for slot in range(4)}
    found = problems(data)  # by the loader (the family's check_pdos hook)
    assert any('nodes.arm.rpdo: 28 valid RPDOs; one S120 Control Unit receives at most 25' in p for p in found), found
    # and by the boot, should a node config reach the master some other way
    config = config_from(example()).nodes[0]
    rpdos = tuple(PdoConfig(64 * (n // 7) + n % 7 + 1, 0x201 + n, mapping=(PdoEntry(0x6040, 0, 16),))
                  for n in range(26))
    port = SimpleNamespace(config=dataclasses.replace(config, rpdo=rpdos, axes=config.axes + tuple(
        AxisConfig(f'j{slot}', slot=slot) for slot in (2, 3))))
    with pytest.raises(S120BootError, match='26 valid RPDOs; one S120 Control Unit receives at most 25'):
        s120_boot.check_limits(port)  # type: ignore[arg-type]


def test_family_hooks_without_a_bus() -> None:
    family = SinamicsS120()
    axis = AxisConfig('a', slot=2, drive={'gear_ratio': 2.0})
    rpdos, tpdos = family.default_pdos(9, [axis], synchronous=False)
    assert [(p.number, p.cob_id, p.transmission) for p in rpdos] == [(129, 0x20A, 254), (130, 0x30A, 254)]
    assert [(p.event_timer, p.transmission) for p in tpdos] == [(10, 254), (10, 254)]
    assert family.axis_objects(2).target_velocity == (0x70FF, 0) and family.axis_objects(0).effort_actual == (
        0x6077, 0)
    assert family.modes.accepted == frozenset({2, 3, 4})
    assert family.streaming_strategy(3, 0) is None  # pv streams only through the position loop
    values, errors = family.parse_axis_options({'gear_ratio': 3, 'offset': 0.5, 'metres_per_revolution': 0.01})
    assert values == {'gear_ratio': 3.0, 'offset': 0.5, 'metres_per_revolution': 0.01} and not errors
