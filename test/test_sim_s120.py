"""The simulated SINAMICS S120 with CBC10 (family ``sinamics_s120``), checked through CAN frames
from a test-side master (canopen RemoteNode, raw frames) on a private virtual channel.

The object dictionaries come from Siemens' real EDS files (../shared/realdata/eds/): the modular
V4.8 file, whose per-DO objects sit in CiA 306 module sections ``[MkFixed....]`` that canopen
skips, expanded here for k modules as a family would (module k's sections as plain objects), and
the flat file (slot 0 only), copied to further slots at +0x40 / +0x80 / +0x800. One test runs
both files through the family's own hook (``prepare_object_dictionary``) as well.

Node 5 with two motor drive objects, p8743 = [4, 3] (slot 0 = DO 4, slot 1 = DO 3) unless said
otherwise. Timing bounds are generous (noisy 2-core CI).
"""
from __future__ import annotations

import struct
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from canopen import ObjectDictionary

from drive_bridge.config.eds import read_object_dictionary
from drive_bridge.sim import SimS120, simulator_for
from drive_bridge.sim.testing import SimBench, SyncLoop, wait_until
from s120tools import (
    BOOT,
    CU,
    EDS_DIR,
    EMCY,
    ENABLED,
    FLAT,
    HAVE_EDS,
    MODULAR,
    NODE,
    P8630,
    SDO_RX,
    SDO_TX,
    SYNC,
    abort_code,
    add,
    emcy_frame,
    emcys,
    enable,
    flat_od,
    inc_per_s,
    modular_od,
    param,
    read,
    rtr,
    select,
    set_param,
    start,
    state,
    wait_state,
    write,
)

pytestmark = pytest.mark.skipif(not HAVE_EDS, reason=f'no SINAMICS EDS in {EDS_DIR}')


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


# -- identity, drive objects, the parameter window -------------------------------------------------------
def test_registered_for_the_family() -> None:
    assert simulator_for('sinamics_s120') is SimS120


def test_two_drive_objects_by_p8743_and_the_p8630_window(bench: SimBench) -> None:
    sim, node = add(bench, rated_torque=[6.0, 12.0], ramp_up_time=[1.5, 2.5])
    assert sim.drive_objects == (4, 3)
    # what the bridge reads at boot, through the window on the Control Unit ...
    assert [param(node, CU, 8743, 'H', i) for i in range(3)] == [4, 3, 0]
    assert param(node, CU, 8848, 'f') == 4.0
    assert param(node, CU, 9, 'H') == 0
    assert param(node, CU, 8684, 'B') == 127
    # ... and on each drive object: selecting DO 3 shows DO 3's values, whatever was selected before
    assert param(node, 3, 333, 'f') == 12.0
    assert read(node, 0x2000 + 1120, 0, 'f') == 2.5
    assert param(node, 4, 333, 'f') == 6.0
    assert read(node, 0x2000 + 1120, 0, 'f') == 1.5
    assert read(node, 0x2000 + 408, 0, 'I') == 2048 and read(node, 0x2000 + 418, 0, 'B') == 11
    assert read(node, 0x2000 + 1300, 0, 'h') == 21  # speed control with encoder
    assert read(node, P8630, 0, 'H') == 4
    select(node, 3)
    assert read(node, 0x2000 + 333, 0, 'f') == 12.0  # the selection is stateful
    # what the window refuses
    assert abort_code(lambda: select(node, 7)) == 0x06090030  # no DO 7
    select(node, 0)
    assert abort_code(lambda: read(node, 0x2000 + 333, 0, 'f')) == 0x06020000  # 0: no access
    select(node, CU)
    assert abort_code(lambda: read(node, 0x2000 + 333, 0, 'f')) == 0x06020000  # not a CU parameter
    assert abort_code(lambda: write(node, 0x2000 + 8743, 0, 'H', 5)) == 0x06010002  # read-only
    assert abort_code(lambda: write(node, 0x2000 + 8684, 0, 'B', 6)) == 0x06090030  # not 4, 5, 127
    select(node, 4)
    assert abort_code(lambda: read(node, 0x2000 + 8848, 0, 'f')) == 0x06020000  # a CU parameter
    assert abort_code(lambda: write(node, 0x2000 + 8641, 0, 'h', 5)) == 0x06090031
    assert abort_code(lambda: write(node, 0x2000 + 1120, 0, 'f', -1.0)) == 0x06090032
    write(node, P8630, 1, 'H', 1)  # sub-index page 1: indices 256..511
    assert abort_code(lambda: read(node, 0x2000 + 333, 0, 'f')) == 0x06090011
    write(node, P8630, 1, 'H', 0)
    # 0x6007 is p8641 of its drive object
    write(node, 0x6807, 0, 'h', 2)  # slot 1 = DO 3
    assert param(node, 3, 8641, 'h') == 2 and param(node, 4, 8641, 'h') == 0
    assert read(node, 0x6007, 0, 'h') == 0


def test_no_0x6064_position_actual_is_0x6063(bench: SimBench) -> None:
    sim, node = add(bench)
    assert abort_code(lambda: node.sdo.upload(0x6064, 0)) == 0x06020000
    assert read(node, 0x6063, 0, 'i') == 0
    assert read(node, 0x6502, 0, 'I') == 0b1110  # vl, pv, pt


# -- NMT -----------------------------------------------------------------------------------------------
def test_p8684_stopped_answers_no_sdo_until_enter_pre_operational(bench: SimBench) -> None:
    sim, node = add(bench, p8684=4)
    assert bench.log.frames(BOOT)[0].data == b'\x00'  # boot-up frame, then STOPPED
    wait_until(lambda: sim.nmt_state == 'STOPPED', 1.0, 'STOPPED')
    t = time.monotonic()
    bench.send(SDO_RX, bytes([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]))  # read 0x1000
    time.sleep(0.3)
    assert bench.log.frames(SDO_TX, since=t) == []
    t = time.monotonic()
    rtr(bench)
    assert bench.log.wait_for(BOOT, since=t, timeout=1.0)[0].data[0] & 0x7F == 4  # guarding: stopped
    bench.nmt(0x80, NODE)
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 1.0, 'PRE-OPERATIONAL')
    assert read(node, 0x1000, 0, 'I') == 0xFFFF0192
    # p8684 applies after reset communication too
    t = time.monotonic()
    bench.nmt(0x82, NODE)
    bench.log.wait_for(BOOT, since=t)
    wait_until(lambda: sim.nmt_state == 'STOPPED', 1.0, 'STOPPED after reset communication')


def test_p8684_operational_starts_by_itself(bench: SimBench) -> None:
    sim, node = add(bench, p8684=5)
    wait_until(lambda: sim.nmt_state == 'OPERATIONAL', 1.0, 'OPERATIONAL')
    frame = bench.log.wait_for(0x180 + NODE, timeout=1.0)[0]  # TPDO1 (statusword, event-driven)
    assert frame.data == struct.pack('<H', 0x0240)  # switch on disabled, remote


def test_cu_reboots_after_p0009_and_keeps_only_what_was_saved(bench: SimBench) -> None:
    sim, node = add(bench)
    select(node, CU)
    assert abort_code(lambda: write(node, 0x2000 + 8848, 0, 'f', 2.0)) == 0x08000022  # needs p0009 = 3
    assert abort_code(lambda: write(node, 0x1010, 2, 'I', 0x65766173)) == 0x08000020  # no full save yet
    assert read(node, 0x1010, 1, 'I') == 1
    write(node, 0x2000 + 9, 0, 'H', 3)  # device configuration
    write(node, 0x2000 + 8848, 0, 'f', 2.0)
    write(node, 0x1010, 1, 'I', 0x65766173)  # save all ("save")
    write(node, 0x1010, 2, 'I', 0x65766173)  # a partial save works now
    set_param(node, 4, 1120, 'f', 3.0)  # not saved: lost at the reboot
    assert sim.effective_p8848 == 4.0  # p8848 takes effect at the reboot
    select(node, CU)
    t = time.monotonic()
    write(node, 0x2000 + 9, 0, 'H', 0)  # the CU reboots by itself
    bench.log.wait_for(BOOT, since=t, timeout=3.0)
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 1.0, 'PRE-OPERATIONAL after the reboot')
    assert sim.effective_p8848 == 2.0
    assert read(node, P8630, 0, 'H') == 0  # the selection starts again at 0
    assert param(node, CU, 8848, 'f') == 2.0
    assert param(node, CU, 9, 'H') == 0
    assert param(node, 4, 1120, 'f') == 10.0
    # restore: factory values at once (in RAM; the memory card keeps the saved ones)
    write(node, 0x1011, 1, 'I', 0x64616F6C)  # "load"
    assert param(node, CU, 8848, 'f') == 4.0
    assert sim.saved_parameter(CU, 8848) == 2.0
    assert abort_code(lambda: write(node, 0x1011, 1, 'I', 0x12345678)) == 0x08000020


# -- modes, units, ramps -----------------------------------------------------------------------------
def test_0x6060_accepts_every_value_and_0x6061_shows_the_mode_in_effect(bench: SimBench) -> None:
    sim, node = add(bench)
    assert read(node, 0x6060, 0, 'b') == 3 and read(node, 0x6061, 0, 'b') == 3
    write(node, 0x6060, 0, 'b', 1)  # pp needs EPOS: accepted, not selected
    assert read(node, 0x6060, 0, 'b') == 1
    time.sleep(0.1)
    assert read(node, 0x6061, 0, 'b') == 3
    write(node, 0x6060, 0, 'b', 4)
    wait_until(lambda: read(node, 0x6061, 0, 'b') == 4, 1.0, '0x6061 = 4 (pt)')
    write(node, 0x6060, 0, 'b', 8)  # no csp
    assert read(node, 0x6060, 0, 'b') == 8
    time.sleep(0.1)
    assert read(node, 0x6061, 0, 'b') == 4
    write(node, 0x6860, 0, 'b', 2)  # slot 1: vl
    wait_until(lambda: read(node, 0x6861, 0, 'b') == 2, 1.0, '0x6861 = 2 (vl)')
    assert sim.view(3).mode == 2 and sim.view(4).requested_mode == 8


def test_profile_velocity_ramps_with_p1120_and_counts_0x6063(bench: SimBench) -> None:
    sim, node = add(bench, ramp_up_time=1.0, ramp_down_time=0.5)  # p1082 3000 rpm: 3000 / 6000 rpm/s
    enable(node, sim, 0)
    target = inc_per_s(1500)
    assert target == 104857600
    t = time.monotonic()
    write(node, 0x60FF, 0, 'i', target)
    time.sleep(0.15)
    speed = sim.view(4).speed_rpm
    assert 0 < speed < 1200 * (time.monotonic() - t) / 0.4 + 50  # ramping: 3000 rpm/s (0.5 s to 1500 rpm)
    wait_until(lambda: read(node, 0x606C, 0, 'i') >= 0.98 * target, 3.0, '1500 rpm')
    assert time.monotonic() - t > 0.35
    assert param(node, 4, 63, 'f') == pytest.approx(1500, abs=30)  # r0063 in rpm
    assert read(node, 0x6083, 0, 'I') == inc_per_s(3000)  # p1082 / p1120 in inc/s^2
    before = time.monotonic()
    p1 = read(node, 0x6063, 0, 'i')
    time.sleep(0.2)
    p2 = read(node, 0x6063, 0, 'i')
    # 1500 rpm between the two reads (timed around them: a busy machine stretches the sleep)
    assert 0.5 * target * 0.2 < p2 - p1 < 2.0 * target * (time.monotonic() - before)
    assert sim.view(3).speed_rpm == 0.0  # the other drive object stays
    # OFF1: ramp down on p1121 (0.25 s from 1500 rpm), then ready to switch on
    t = time.monotonic()
    write(node, 0x6040, 0, 'H', 0x06)
    wait_state(sim, 0, 'READY_TO_SWITCH_ON')
    assert time.monotonic() - t > 0.15
    assert abs(sim.view(4).speed_rpm) < 50


def test_units_without_encoder_are_rpm(bench: SimBench) -> None:
    sim, node = add(bench, encoder=[True, False], ramp_up_time=0.0)
    enable(node, sim, 1)
    write(node, 0x68FF, 0, 'i', 600)  # rpm
    wait_until(lambda: abs(read(node, 0x686C, 0, 'i') - 600) <= 6, 2.0, '600 rpm on slot 1')
    assert read(node, 0x6863, 0, 'i') == 0  # no encoder, no position
    assert param(node, 3, 1300, 'h') == 20


def test_profile_torque_per_mille_of_r0333(bench: SimBench) -> None:
    sim, node = add(bench, mode=[4, 3], rated_torque=8.0)
    assert read(node, 0x6061, 0, 'b') == 4 and param(node, 4, 1300, 'h') == 23
    enable(node, sim, 0)
    write(node, 0x6071, 0, 'h', 250)  # 25 % of r0333
    wait_until(lambda: sim.view(4).speed_rpm > 100, 2.0, 'the load accelerates')
    assert read(node, 0x6074, 0, 'h') == 250
    assert param(node, 4, 79, 'f') == pytest.approx(2.0)  # r0079 in N m
    assert sim.view(3).speed_rpm == 0.0


# -- PDOs -------------------------------------------------------------------------------------------
def test_synchronous_rpdo_takes_effect_at_the_next_sync(bench: SimBench) -> None:
    sim, node = add(bench)
    start(bench, sim)
    write(node, 0x1401, 2, 'B', 1)  # RPDO2 (controlword, target velocity) synchronous
    rpdo2 = 0x300 + NODE
    bench.send(SYNC, b'')  # SYNC k
    time.sleep(0.05)
    bench.send(rpdo2, struct.pack('<Hi', 0, 1234))
    time.sleep(0.1)
    assert read(node, 0x60FF, 0, 'i') == 0  # not before SYNC k + 1
    bench.send(SYNC, b'')  # SYNC k + 1
    wait_until(lambda: read(node, 0x60FF, 0, 'i') == 1234, 1.0, '0x60FF = 1234 at SYNC k + 1')
    write(node, 0x1401, 2, 'B', 0xFE)  # asynchronous (the default): at once
    bench.send(rpdo2, struct.pack('<Hi', 0, 777))
    wait_until(lambda: read(node, 0x60FF, 0, 'i') == 777, 1.0, '0x60FF = 777 without SYNC')


def test_mapping_sub0_read_only_as_the_manual_lists_it(bench: SimBench) -> None:
    sim, node = add(bench, mapping_sub0_read_only=True)
    assert abort_code(lambda: write(node, 0x1641, 0, 'B', 0)) == 0x06010002
    # the manual's remapping of axis 2's RPDO2 (Tab. 4-2): COB-ID invalid, entries, COB-ID valid
    write(node, 0x1441, 1, 'I', 0x80000000 | read(node, 0x1441, 1, 'I'))
    assert abort_code(lambda: write(node, 0x1601, 1, 'I', 0x60400010)) == 0x08000022  # slot 0's is valid
    write(node, 0x1641, 1, 'I', 0x68400010)
    write(node, 0x1641, 2, 'I', 0x68FF0020)
    write(node, 0x1641, 3, 'I', 0)
    write(node, 0x1641, 4, 'I', 0)
    assert read(node, 0x1641, 0, 'B') == 2
    write(node, 0x1441, 1, 'I', 0x2F0)
    start(bench, sim)
    bench.send(0x2F0, struct.pack('<Hi', 0x06, 500))
    wait_state(sim, 1, 'READY_TO_SWITCH_ON')
    assert read(node, 0x68FF, 0, 'i') == 500


def test_mapping_sub0_writable_by_default(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x1641, 0, 'B', 0)  # slot 1's PDOs start invalid: the CiA 301 procedure works
    write(node, 0x1641, 1, 'I', 0x68400010)
    write(node, 0x1641, 0, 'B', 1)
    assert read(node, 0x1641, 0, 'B') == 1


def test_a08751_when_rpdos_come_faster_than_twice_p8848(bench: SimBench) -> None:
    sim, node = add(bench)
    start(bench, sim)
    write(node, 0x1401, 2, 'B', 1)
    rpdo2 = 0x300 + NODE

    def send_rpdo(i: int) -> None:
        bench.send(rpdo2, struct.pack('<Hi', 0, 0))

    t = time.monotonic()
    SyncLoop(bench.master, 0.02).run(12, before=send_rpdo)  # 20 ms >= 2 x 4 ms: fine
    assert emcys(bench, since=t) == []
    t = time.monotonic()
    SyncLoop(bench.master, 0.003).run(40, before=send_rpdo)  # 3 ms < 8 ms
    frame = emcy_frame(0x8110, 0x11, 8751, 4)
    wait_until(lambda: frame in emcys(bench, since=t), 1.0, 'EMCY 0x8110 A08751 of DO 4')
    assert read(node, 0x6041, 0, 'H') & 0x80  # the warning bit
    assert sim.view(4).alarms == (8751,)
    t = time.monotonic()
    SyncLoop(bench.master, 0.02).run(12, before=send_rpdo)
    wait_until(lambda: bytes(8) in emcys(bench, since=t), 1.0, 'EMCY 0x0000: A08751 gone')
    assert not read(node, 0x6041, 0, 'H') & 0x80


def test_a08758_beyond_25_valid_rpdos(bench: SimBench) -> None:
    sim, node = add(bench, modular_od(4), do_numbers=[2, 3, 4, 5])
    assert sim.valid_rpdos == 4  # slot 0's predefined RPDO1..4
    cob = iter(range(0x220, 0x260))
    made: list[tuple[int, int, int]] = []  # (slot, COB-ID, comm index)

    def validate(slot: int, k: int) -> None:
        index = 0x1400 + 0x40 * slot + k
        if k >= 4:  # RPDO5..8 are empty: map the slot's controlword
            write(node, 0x1600 + 0x40 * slot + k, 1, 'I', 0x60400010 + (0x800 * slot << 16))
            write(node, 0x1600 + 0x40 * slot + k, 0, 'B', 1)
        made.append((slot, next(cob), index))
        write(node, index, 1, 'I', made[-1][1])

    t = time.monotonic()
    for slot in (1, 2, 3):
        for k in range(4):
            validate(slot, k)
    for k in (4, 5, 6, 7):
        for slot in (0, 1, 3):
            if sim.valid_rpdos < 25:
                validate(slot, k)
    assert sim.valid_rpdos == 25 and emcys(bench, since=t) == []
    validate(2, 4)  # the 26th
    assert sim.valid_rpdos == 26
    frame = emcy_frame(0x1001, 0x11, 8758, CU)
    wait_until(lambda: frame in emcys(bench, since=t), 1.0, 'EMCY 0x1001 A08758 of the CU')
    assert sim.view(CU).alarms == (8758,)
    # only the first 25 are received: the 26th (slot 2's controlword) does nothing
    start(bench, sim)
    bench.send(made[-1][1], struct.pack('<H', 0x06))
    time.sleep(0.15)
    assert state(sim, 2) == 'SWITCH_ON_DISABLED'
    t = time.monotonic()
    write(node, made[0][2], 1, 'I', 0x80000000 | made[0][1])  # one less
    wait_until(lambda: bytes(8) in emcys(bench, since=t), 1.0, 'EMCY 0x0000: A08758 gone')
    bench.send(made[-1][1], struct.pack('<H', 0x06))
    wait_state(sim, 2, 'READY_TO_SWITCH_ON')


# -- EMCY, faults, alarms ------------------------------------------------------------------------------
def test_emcy_layout_and_acknowledge_by_0x1003(bench: SimBench) -> None:
    sim, node = add(bench)
    enable(node, sim, 0)
    enable(node, sim, 1)
    t = time.monotonic()
    sim.inject_fault(7900, 3, value=5)
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes.fromhex('0010 81 dc1e 03 0000')
    wait_state(sim, 1, 'FAULT')
    assert state(sim, 0) == ENABLED
    assert read(node, 0x1001, 0, 'B') == 0x81
    assert read(node, 0x6841, 0, 'H') & 0x4F == 0x08  # fault
    assert param(node, 3, 947, 'H') == 7900 and param(node, 3, 949, 'i') == 5
    # 0x1003 per module: slot 1 = module 2 (count 0x0B, entries 0x0C..), number << 16 | code
    assert read(node, 0x1003, 0, 'B') == 1
    assert [read(node, 0x1003, s, 'I') for s in (1, 2, 0x0B, 0x0C, 0x0D, 0x4A)] == \
        [2, 0, 1, 7900 << 16 | 0x1000, 0, 0]
    t = time.monotonic()
    sim.inject_fault(7901, 4, persistent=True, reaction='OFF3')
    assert bench.log.wait_for(EMCY, since=t)[0].data == emcy_frame(0x1000, 0x81, 7901, 4)
    wait_state(sim, 0, 'FAULT')
    assert read(node, 0x1003, 0, 'B') == 2
    assert [read(node, 0x1003, s, 'I') for s in (2, 3)] == [1, 7901 << 16 | 0x1000]
    # writing 0 to 0x1003:0 acknowledges every DO; DO 4's cause is still there
    t = time.monotonic()
    write(node, 0x1003, 0, 'B', 0)
    wait_state(sim, 1, 'SWITCH_ON_DISABLED')
    assert state(sim, 0) == 'FAULT'
    assert read(node, 0x1003, 0, 'B') == 1
    assert bytes(8) not in emcys(bench, since=t)
    sim.clear_cause(7901, do=4)
    write(node, 0x1003, 0, 'B', 0)
    wait_state(sim, 0, 'SWITCH_ON_DISABLED')
    wait_until(lambda: bytes(8) in emcys(bench, since=t), 1.0, 'EMCY 0x0000')
    assert read(node, 0x1001, 0, 'B') == 0 and read(node, 0x1003, 0, 'B') == 0


def test_fault_acknowledge_by_controlword_bit_7(bench: SimBench) -> None:
    sim, node = add(bench)
    t = time.monotonic()
    sim.inject_fault(8701, 4)  # a CAN-range fault: 0x1001, register bits 0 and 4
    assert bench.log.wait_for(EMCY, since=t)[0].data == emcy_frame(0x1001, 0x11, 8701, 4)
    wait_state(sim, 0, 'FAULT')
    t = time.monotonic()
    write(node, 0x6040, 0, 'H', 0x80)
    wait_state(sim, 0, 'SWITCH_ON_DISABLED')
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes(8)
    assert sim.view(4).faults == ()


def test_messages_over_nmt_resets(bench: SimBench) -> None:
    sim, node = add(bench)
    sim.inject_fault(7900, 4, persistent=True)
    sim.inject_fault(7800, 3)
    t = time.monotonic()
    bench.nmt(0x82, NODE)  # reset communication: 0x1003 still lists both
    bench.log.wait_for(BOOT, since=t)
    assert read(node, 0x1003, 0, 'B') == 2 and sim.active_messages == ('F07900@4', 'F07800@3')
    t = time.monotonic()
    bench.nmt(0x81, NODE)  # reset node: the application restarts, a persisting cause faults again
    bench.log.wait_for(BOOT, since=t)
    assert bench.log.wait_for(EMCY, since=t)[0].data == emcy_frame(0x1000, 0x81, 7900, 4)
    wait_state(sim, 0, 'FAULT')
    assert state(sim, 1) == 'SWITCH_ON_DISABLED'
    assert read(node, 0x1003, 0, 'B') == 1 and sim.view(3).faults == ()


def test_alarm_outside_the_can_range_sets_the_warning_bit_only(bench: SimBench) -> None:
    sim, node = add(bench)
    t = time.monotonic()
    sim.inject_alarm(7910, 4)
    time.sleep(0.2)
    assert emcys(bench, since=t) == []
    assert read(node, 0x6041, 0, 'H') & 0x80 and not read(node, 0x6841, 0, 'H') & 0x80
    assert read(node, 0x1001, 0, 'B') == 0 and read(node, 0x1003, 0, 'B') == 0
    assert param(node, 4, 2110, 'H') == 7910
    sim.clear_cause(7910, 4)
    assert not read(node, 0x6041, 0, 'H') & 0x80
    # a CAN-range alarm sends its EMCY
    sim.inject_alarm(8752, 3)
    assert bench.log.wait_for(EMCY, since=t)[0].data == emcy_frame(0x8120, 0x11, 8752, 3)
    assert read(node, 0x6841, 0, 'H') & 0x80 and read(node, 0x1003, 0x0C, 'I') == 8752 << 16 | 0x8120
    t = time.monotonic()
    sim.clear_cause(8752)
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes(8)
    time.sleep(0.2)
    assert emcys(bench, since=t) == [bytes(8)]


# -- error control -----------------------------------------------------------------------------------
def test_life_guarding_with_the_p8641_reactions(bench: SimBench) -> None:
    sim, node = add(bench, p8641=[2, 0])  # DO 4: OFF2, DO 3: no reaction (factory)
    enable(node, sim, 0)
    enable(node, sim, 1)
    write(node, 0x100C, 0, 'H', 50)
    write(node, 0x100D, 0, 'B', 4)  # node life time 200 ms
    replies: list[int] = []
    for _ in range(3):
        t = time.monotonic()
        rtr(bench)
        replies.append(bench.log.wait_for(BOOT, since=t)[0].data[0])
        time.sleep(0.05)
    assert replies == [0x7F, 0xFF, 0x7F]  # pre-operational, toggling
    t = time.monotonic()
    lost = {emcy_frame(0x8130, 0x11, 8700, 4), emcy_frame(0x8130, 0x11, 8700, 3)}
    wait_until(lambda: lost <= set(emcys(bench, since=t)), 2.0, 'EMCY 0x8130 F08700 of DO 4 and DO 3')
    wait_state(sim, 0, 'FAULT')  # p8641 = 2
    assert state(sim, 1) == ENABLED and read(node, 0x6841, 0, 'H') & 0x80  # p8641 = 0: an alarm
    assert sim.view(4).faults == (8700,) and sim.view(3).alarms == (8700,)
    assert read(node, 0x1001, 0, 'B') == 0x11 and sim.nmt_state == 'PRE-OPERATIONAL'  # p8609 = 1
    assert param(node, 4, 949, 'i') == 2  # fault value 2
    t = time.monotonic()
    rtr(bench)  # the master is back: the alarm goes, the fault can be acknowledged
    wait_until(lambda: sim.view(3).alarms == (), 1.0, 'A08700 gone')
    write(node, 0x6040, 0, 'H', 0x80)
    wait_state(sim, 0, 'SWITCH_ON_DISABLED')
    wait_until(lambda: bytes(8) in emcys(bench, since=t), 1.0, 'EMCY 0x0000')
    # p8609[0] = 2: the node goes to STOPPED on the next loss
    set_param(node, CU, 8609, 'I', 2)
    assert read(node, 0x1029, 1, 'B') == 2
    rtr(bench)
    wait_until(lambda: sim.nmt_state == 'STOPPED', 2.0, 'STOPPED after the guarding loss')


def test_heartbeat_and_guarding_exclude_each_other(bench: SimBench) -> None:
    sim, node = add(bench, p8641=1)
    write(node, 0x100C, 0, 'H', 20)
    write(node, 0x100D, 0, 'B', 2)
    write(node, 0x1017, 0, 'H', 1000)  # heartbeat producer: guarding off
    t = time.monotonic()
    first = bench.log.wait_for(BOOT, since=t, timeout=2.0)[-1].timestamp
    rtr(bench)
    time.sleep(0.3)
    assert [f.data for f in bench.log.frames(BOOT, since=first + 0.01)] == []  # no reply, no heartbeat yet
    assert emcys(bench, since=t) == []  # life guarding is off too
    write(node, 0x1017, 0, 'H', 0)
    t = time.monotonic()
    rtr(bench)
    assert bench.log.wait_for(BOOT, since=t)[0].data[0] & 0x7F == 0x7F
    assert abort_code(lambda: node.sdo.upload(0x1016, 1)) == 0x06020000  # no heartbeat consumer


# -- both real EDS files -----------------------------------------------------------------------------
def _family_od(path: Path, slots: list[int]) -> ObjectDictionary:
    from drive_bridge.families.errors import FamilyError
    from drive_bridge.families.registry import get_family
    try:
        family = get_family('sinamics_s120')
    except FamilyError:
        pytest.skip('the sinamics_s120 family is not registered')
    od, _ = read_object_dictionary(path, NODE)
    problems = family.prepare_object_dictionary(od, slots)
    assert list(problems) == []
    return od


@pytest.mark.parametrize('eds, expanded_by', [('modular', 'test'), ('flat', 'test'), ('modular', 'family'),
                                              ('flat', 'family')])
def test_both_real_eds_files_give_a_two_axis_node(bench: SimBench, eds: str, expanded_by: str) -> None:
    if expanded_by == 'family':
        od = _family_od(MODULAR if eds == 'modular' else FLAT, [0, 1])
    else:
        od = modular_od(2) if eds == 'modular' else flat_od(2)
    sim, node = add(bench, od, ramp_up_time=0.0)
    assert [param(node, CU, 8743, 'H', i) for i in (0, 1)] == [4, 3]
    assert read(node, 0x1440, 1, 'I') & 0x80000000  # only slot 0 has predefined COB-IDs
    assert read(node, 0x1600, 1, 'I') == 0x60400010 and read(node, 0x1640, 1, 'I') == 0x68400010
    t = time.monotonic()
    start(bench, sim)
    assert bench.log.wait_for(0x180 + NODE, since=t)[0].data == struct.pack('<H', 0x0240)  # TPDO1, slot 0
    write(node, 0x1840, 1, 'I', 0x190)  # slot 1's TPDO1 made valid
    enable(node, sim, 1)
    write(node, 0x68FF, 0, 'i', inc_per_s(300))
    wait_until(lambda: abs(sim.view(3).speed_rpm - 300) < 3, 2.0, 'slot 1 at 300 rpm')
    assert struct.pack('<H', 0x0237) in [f.data for f in bench.log.frames(0x190, since=t)]
    p1 = read(node, 0x6863, 0, 'i')
    time.sleep(0.1)
    assert read(node, 0x6863, 0, 'i') > p1
    assert read(node, 0x686C, 0, 'i') == pytest.approx(inc_per_s(300), rel=0.01)
    bench.send(0x200 + NODE, struct.pack('<H', 0x06))  # RPDO1 of slot 0 (asynchronous)
    wait_state(sim, 0, 'READY_TO_SWITCH_ON')
    assert state(sim, 1) == ENABLED
