"""The core master against simulated drives, through CAN frames only (no ROS).

Three drives from the demo configuration, node 3 with two axes: boot, enable, motion in
PP, PV, CSP and CSV, faults with decoded EMCY, heartbeat loss, SDO aborts, boot failures.
The simulators are inspected only to check what the master achieved.
"""
from __future__ import annotations

import dataclasses
import math
import time

import pytest
from canopen.objectdictionary import datatypes as dt

from bustools import config_from, demo_data, eventually, running
from drive_bridge.cia402.errors import AxisError
from drive_bridge.cia402.statemachine import State
from drive_bridge.joint import Setpoint
from drive_bridge.master.errors import SdoError
from drive_bridge.master.events import EventKind
from timingtools import BUSY_SLACK

JOINTS = ('base_joint', 'shoulder_joint', 'elbow_joint', 'lift_joint')
SLOTS = {'base_joint': (2, 0), 'shoulder_joint': (3, 0), 'elbow_joint': (3, 1), 'lift_joint': (4, 0)}


def sim_axis(sim, joint):
    node_id, slot = SLOTS[joint]
    return sim.drive(node_id).axis(slot)


def counts_to_si(master, joint, counts):
    return master.axes[joint].config.scaling.position_to_si(counts)


def test_boots_three_drives_and_enables_every_axis() -> None:
    with running(config_from(demo_data())) as (master, sim):
        snapshot = master.snapshot()
        assert [n.boot_state.value for n in snapshot.nodes] == ['operational'] * 3
        assert {a.joint for a in snapshot.axes} == set(JOINTS)
        for joint in JOINTS:
            master.axes[joint].enable(timeout=2.0)
        for joint in JOINTS:
            assert master.axes[joint].snapshot().state is State.OPERATION_ENABLED
            assert sim_axis(sim, joint).state is State.OPERATION_ENABLED  # the drive itself agrees
        # PDO configuration reached the drives: node 3 sends both axes' statuswords
        assert sim.drive(3).nmt_state == 'OPERATIONAL'


@pytest.mark.slow
@pytest.mark.parametrize('joint', JOINTS)
def test_each_axis_moves_in_pp_pv_csp_and_csv(joint: str) -> None:
    with running(config_from(demo_data())) as (master, sim):
        axis = master.axes[joint]
        drive = sim_axis(sim, joint)
        axis.enable(timeout=2.0)
        limits = axis.config.limits
        span = (limits.max_position - limits.min_position) if limits.max_position is not None else 1.0
        start = axis.snapshot().position

        # profile position: set-point handshake, target reached, position in SI matches the drive
        axis.set_mode('pp')
        target = start + 0.1 * span
        axis.command(position=target)
        axis.wait_target_reached(timeout=5.0)
        reached = axis.snapshot().position
        assert reached == pytest.approx(target, abs=2e-3 * span)
        assert reached == pytest.approx(counts_to_si(master, joint, drive.position), abs=1e-6 * span)

        # profile velocity: the drive ramps to the commanded velocity
        axis.set_mode('pv')
        velocity = 0.2 * (limits.max_velocity or 1.0)
        axis.command(velocity=velocity)
        eventually(lambda: abs(axis.snapshot().velocity - velocity) < 0.02 * abs(velocity), 3.0, 'pv velocity')
        before = axis.snapshot().position
        time.sleep(0.2)
        assert axis.snapshot().position > before
        axis.command(velocity=0.0)
        eventually(lambda: abs(axis.snapshot().velocity) < 1e-3, 3.0, 'pv stop')

        # cyclic synchronous position: a ramp streamed one set-point per SYNC
        axis.set_mode('csp')
        p0 = axis.commanded_position()
        rate = 0.15 * (limits.max_velocity or 1.0)
        t0 = time.time()
        axis.set_setpoint_source(lambda t: Setpoint(position=p0 + rate * min(t - t0, 0.5)))
        time.sleep(0.8)
        assert axis.snapshot().position == pytest.approx(p0 + rate * 0.5, abs=0.01 * span)
        assert abs(drive.following_error) < 20000  # inside the following error window (0x6065)

        # cyclic synchronous velocity: a trapezoid within the drive's max acceleration (0x60C5,
        # the joint's limit; a step would be refused by the cycle check)
        axis.set_mode('csv')
        before = axis.snapshot().position
        t0 = time.time()
        axis.set_setpoint_source(lambda t: Setpoint(
            velocity=-rate * max(0.0, min(1.0, (t - t0) / 0.1, (0.6 - (t - t0)) / 0.1))))
        time.sleep(0.8)
        moved = axis.snapshot().position - before
        assert moved == pytest.approx(-rate * 0.5, rel=0.15)
        assert axis.snapshot().state is State.OPERATION_ENABLED


def test_injected_fault_is_decoded_and_reset_on_the_rising_edge() -> None:
    with running(config_from(demo_data())) as (master, sim):
        emcys = []
        master.add_emcy_listener(emcys.append)
        axis = master.axes['base_joint']
        axis.enable(timeout=2.0)
        sim.drive(2).inject_fault(0x2310, manufacturer=b'\x01\x02\x03\x04\x05')
        event = eventually(lambda: next((e for e in emcys if e.code == 0x2310), None), 2.0, 'EMCY 0x2310')
        assert (event.node_id, event.node_name, event.text) == (2, 'base_drive', 'continuous over-current')
        assert event.manufacturer == b'\x01\x02\x03\x04\x05' and event.register & 0x01
        eventually(lambda: axis.snapshot().state is State.FAULT, 2.0, 'FAULT state')
        snapshot = axis.snapshot()
        assert snapshot.fault and snapshot.last_emcy is not None and snapshot.last_emcy.code == 0x2310
        with pytest.raises(AxisError, match='clear it with ~/fault_reset') as refused:
            axis.enable(timeout=0.5)
        assert 'continuous over-current' in str(refused.value)
        axis.reset_fault(timeout=2.0)
        assert axis.snapshot().state is State.SWITCH_ON_DISABLED
        assert axis.snapshot().last_emcy is None  # cleared by the reset
        axis.enable(timeout=2.0)
        assert sim_axis(sim, 'base_joint').state is State.OPERATION_ENABLED


def test_a_persistent_fault_survives_the_reset_until_its_cause_is_gone() -> None:
    with running(config_from(demo_data())) as (master, sim):
        axis = master.axes['elbow_joint']
        axis.enable(timeout=2.0)
        master.axes['shoulder_joint'].enable(timeout=2.0)
        sim.drive(3).inject_fault(0x4310, axis=1, persistent=True)
        eventually(lambda: axis.snapshot().state is State.FAULT, 2.0, 'FAULT on the second axis')
        assert master.axes['shoulder_joint'].snapshot().state is State.OPERATION_ENABLED
        with pytest.raises(AxisError, match='cause is still present') as still:
            axis.reset_fault(timeout=0.5)
        assert 'excess temperature drive' in str(still.value)
        sim.drive(3).clear_fault_cause(1)
        axis.reset_fault(timeout=2.0)
        assert axis.snapshot().state is State.SWITCH_ON_DISABLED


def test_a_stopped_heartbeat_is_reported_within_its_time_and_axes_become_unavailable() -> None:
    with running(config_from(demo_data())) as (master, sim):
        events = []
        master.add_event_listener(events.append)
        node = master.nodes['lift_drive']
        limit = node.heartbeat_timeout
        assert limit == pytest.approx(0.3)  # 100 ms producer x 3
        sim.drive(4).stop_heartbeat()
        stopped = time.monotonic()
        lost = eventually(lambda: next((e for e in events if e.kind is EventKind.HEARTBEAT_LOST), None),
                          3.0, 'heartbeat lost event')
        assert time.monotonic() - stopped < limit + BUSY_SLACK  # last heartbeat + limit + supervision
        assert 'node 4 (lift_drive): heartbeat lost' in lost.message
        assert not master.axes['lift_joint'].snapshot().available
        assert master.axes['base_joint'].snapshot().available
        sim.drive(4).start_heartbeat()
        eventually(lambda: master.axes['lift_joint'].snapshot().available, 3.0, 'heartbeat back')
        assert any(e.kind is EventKind.HEARTBEAT_BACK for e in events)


def test_sdo_aborts_are_reported_with_code_and_text() -> None:
    with running(config_from(demo_data())) as (master, sim):
        with pytest.raises(SdoError) as missing:
            master.sdo_read(2, 0x2345, 0, dt.UNSIGNED32)
        assert missing.value.abort_code == 0x06020000
        assert 'node 2 object 0x2345:00: SDO abort 0x06020000: object does not exist' in str(missing.value)
        sim.drive(2).abort_sdo_on(0x6065, 0, 0x08000022)
        with pytest.raises(SdoError) as refused:
            master.sdo_write(2, 0x6065, 0, 5000)
        assert refused.value.abort_code == 0x08000022
        assert 'because of the present device state' in str(refused.value)
        data_type, vendor, raw = master.sdo_read(3, 0x1018, 2)  # type from the EDS
        assert (data_type, vendor, raw) == (dt.UNSIGNED32, 0x402, b'\x02\x04\x00\x00')
        with pytest.raises(SdoError, match='give its data type explicitly'):
            master.sdo_read(3, 0x2345, 0)


def test_one_node_failing_to_boot_does_not_stop_the_others_and_is_retried() -> None:
    config = config_from(demo_data())
    nodes = tuple(dataclasses.replace(n, timeouts=dataclasses.replace(
        n.timeouts, boot=0.3, boot_retries=1, boot_retry_interval=0.5)) for n in config.nodes)
    config = dataclasses.replace(config, nodes=nodes)
    with running(config, wait=False) as (master, sim):
        events = []
        master.add_event_listener(events.append)
        sim.drive(4).mute(True)
        master.wait_until_operational(5.0, ['base_drive', 'arm_drive'])
        failed = eventually(lambda: next((e for e in events if e.kind is EventKind.BOOT_FAILED), None),
                            5.0, 'boot failure of node 4')
        assert failed.node_id == 4
        assert 'node 4 (lift_drive) boot step "reset communication": no boot-up message (COB-ID 0x704) ' \
               'within 300 ms' in failed.message
        sim.drive(4).mute(False)
        master.wait_until_operational(5.0)
        assert master.nodes['lift_drive'].boot_attempts >= 3


def test_identity_mismatch_names_the_object_and_both_values() -> None:
    data = demo_data()
    data['nodes']['base_drive']['vendor_id'] = 0x1234
    data['nodes']['base_drive']['boot_retries'] = 0
    with running(config_from(data), wait=False) as (master, _sim):
        events = []
        master.add_event_listener(events.append)
        failed = eventually(lambda: next((e for e in events if e.kind is EventKind.BOOT_FAILED), None),
                            5.0, 'identity failure')
        assert 'node 2 (base_drive) boot step "identity": vendor-ID 0x1018:01 is 0x00000000, ' \
               'the configuration expects 0x00001234' in failed.message
        master.wait_until_operational(5.0, ['arm_drive', 'lift_drive'])


def test_a_node_that_reboots_is_configured_again() -> None:
    with running(config_from(demo_data())) as (master, sim):
        events = []
        master.add_event_listener(events.append)
        master.nmt(0x81, 3)  # NMT reset node
        eventually(lambda: any(e.kind is EventKind.UNEXPECTED_BOOT for e in events), 3.0, 'reboot noticed')
        master.wait_until_operational(5.0)
        master.axes['elbow_joint'].enable(timeout=2.0)
        assert math.isfinite(master.axes['elbow_joint'].snapshot().position)


def test_an_external_sync_producer_drives_the_cycle() -> None:
    import canopen
    data = demo_data()
    data['master']['sync_producer'] = 'external'
    config = config_from(data)
    producer = canopen.Network()
    producer.connect(interface='virtual', channel=config.bus.channel)
    try:
        producer.sync.start(0.004)  # e.g. a drive or an adapter produces SYNC
        with running(config) as (master, sim):
            assert master.sync is None  # the bridge sends no SYNC of its own
            axis = master.axes['base_joint']
            axis.enable(timeout=2.0)  # the controlword RPDOs follow the external SYNC
            p0 = axis.commanded_position()
            t0 = time.time()
            axis.set_setpoint_source(lambda t: Setpoint(position=p0 + 0.2 * min(time.time() - t0, 0.5)))
            time.sleep(0.8)
            assert axis.snapshot().position == pytest.approx(p0 + 0.1, abs=2e-3)
            assert sim.drive(2).received_sync_count > 100
    finally:
        producer.sync.stop()
        producer.disconnect()


def test_malformed_frames_are_counted_or_decoded_and_the_master_keeps_running() -> None:
    import can
    with running(config_from(demo_data())) as (master, sim):
        emcys = []
        master.add_emcy_listener(emcys.append)
        axis = master.axes['base_joint']
        axis.enable(timeout=2.0)
        rogue = can.Bus(interface='virtual', channel=master.config.bus.channel)
        try:
            for frame in (
                    can.Message(arbitration_id=0x182, data=b'\x37', is_extended_id=False),  # TPDO1 1 of 5 bytes
                    can.Message(arbitration_id=0x702, data=b'', is_extended_id=False),  # heartbeat, no state
                    can.Message(arbitration_id=0x082, data=b'\x10\x23\x03', is_extended_id=False),  # short EMCY
                    can.Message(arbitration_id=0x582, data=b'\xff' * 8, is_extended_id=False),  # unasked SDO
                    can.Message(arbitration_id=0x182, is_remote_frame=True, is_extended_id=False),  # RTR
                    can.Message(arbitration_id=0x1ABCDEF, data=b'\x00' * 8, is_extended_id=True),  # 29-bit
                    can.Message(arbitration_id=0x7FF, data=b'\x01\x02', is_extended_id=False)):  # unknown id
                rogue.send(frame)
            snapshot = eventually(lambda: next((n for n in master.snapshot().nodes if n.pdo_errors), None), 2.0,
                                  'the short TPDO counted')
            assert snapshot.last_pdo_error == 'TPDO 0x182: 1 byte(s) received, mapping needs 5'
            short = eventually(lambda: next((e for e in emcys if e.code == 0x2310), None), 2.0, 'short EMCY decoded')
            assert short.register == 0x03 and short.manufacturer == b'\x00' * 5
        finally:
            rogue.shutdown()
        # everything still works: SYNC runs, the axis follows commands, SDO answers
        cycles = master.sync.cycles
        time.sleep(0.2)
        assert master.sync.cycles > cycles + 10
        assert axis.snapshot().state is not State.UNKNOWN and master.nodes['base_drive'].available
        assert master.sdo_read(2, 0x1018, 2)[1] == 0x402


def test_a_polled_input_the_drive_refuses_is_reported_once_and_counted() -> None:
    with running(config_from(demo_data())) as (master, sim):
        node = master.nodes['base_drive']
        sim.drive(2).abort_sdo_on(0x60F4, 0, 0x06020000)  # object does not exist
        node.read(0x60F4)  # not in a TPDO: polled by SDO from now on
        eventually(lambda: node.worker.failures > 20, 5.0, 'the poll failing repeatedly')
        reported = [e for e in master.events if '60F4' in e.message.upper()]
        assert len(reported) == 1, [e.message for e in reported]
        sim.drive(2).abort_sdo_on(0x60F4, 0, None)
        eventually(lambda: node.read(0x60F4) is not None, 2.0, 'the poll succeeding')
        failures = node.worker.failures
        sim.drive(2).abort_sdo_on(0x60F4, 0, 0x06020000)  # failing again: reported again
        eventually(lambda: node.worker.failures > failures, 2.0, 'failing again')
        eventually(lambda: len([e for e in master.events if '60F4' in e.message.upper()]) == 2, 2.0, 'reported again')
