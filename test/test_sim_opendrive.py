"""The simulated OPEN drive (family ``opendrive``), checked through CAN frames from a test-side
master (canopen RemoteNode with the shipped EDS, raw frames) on a private virtual channel.

Figures: n_MAX = 3000 rpm, T_nom = 10 N m, 4 pole pairs, f_pwm = 8 kHz (the simulator's
defaults); array element k at sub-index k + 1. Timing bounds are generous (noisy 2-core CI).
"""
from __future__ import annotations

import struct
import time
from collections.abc import Iterator

import pytest

from drive_bridge.families.opendrive.parameter_table import decode_format
from drive_bridge.sim import SimOpenDrive, simulator_for
from drive_bridge.sim.testing import SimBench, SyncLoop, wait_until
from opendrivetools import (
    EMCY,
    GUARD,
    HIGH,
    NODE,
    OPERATIONAL,
    PRE_OPERATIONAL,
    RPDO1,
    SDO_RX,
    SDO_TX,
    TPDO1,
    abort_code,
    add,
    emcy_frames,
    power_cycle,
    read,
    rtr,
    set_param,
    start,
    write,
)


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


# ---- communication ---------------------------------------------------------------------------------
def test_registered_and_no_heartbeat_objects(bench: SimBench) -> None:
    assert simulator_for('opendrive') is SimOpenDrive
    sim, node = add(bench)
    assert bench.log.frames(GUARD)[0].data == b'\x00'  # boot-up
    for index in (0x1016, 0x1017):
        assert abort_code(lambda index=index: node.sdo.upload(index, 0)) == 0x06020000
    assert abort_code(lambda: node.sdo.upload(0x6040, 0)) == 0x06020000  # no CiA 402
    assert read(node, 0x1000, 0, 'I') == 0
    time.sleep(0.2)
    assert len(bench.log.frames(GUARD)) == 1, 'no heartbeat frames'


def test_node_guarding_replies_carry_the_toggle_and_the_state(bench: SimBench) -> None:
    sim, _node = add(bench)
    assert [rtr(bench), rtr(bench)] == [bytes([PRE_OPERATIONAL]), bytes([0x80 | PRE_OPERATIONAL])]
    start(bench, sim)
    assert rtr(bench) == bytes([OPERATIONAL])


def test_life_guarding_does_nothing_by_default(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x100C, 0, 'H', 50)
    write(node, 0x100D, 0, 'B', 3)
    t = time.monotonic()
    rtr(bench)  # arms life guarding
    wait_until(lambda: sim.guarding_lost, 1.5, 'life guarding event')
    assert sim.run_input and not emcy_frames(bench, since=t)


def test_life_guarding_stop_option_and_the_life_time_clamp(bench: SimBench) -> None:
    # f_pwm = 32767 Hz: the life time is clamped to 1 s although 0x100C x 0x100D = 5 s
    sim, node = add(bench, life_guarding_reaction='stop', pwm_frequency=32767.0)
    write(node, 0x100C, 0, 'H', 1000)
    write(node, 0x100D, 0, 'B', 5)
    time.sleep(0.3)
    assert sim.run_input, 'life guarding waits for the first RTR'
    rtr(bench)
    t = time.monotonic()
    wait_until(lambda: not sim.run_input, 3.0, 'RUN forced low')
    assert 0.8 <= time.monotonic() - t <= 2.5
    assert read(node, 0x2021, 0, 'I') & 1 == 0
    rtr(bench)
    wait_until(lambda: sim.run_input, 0.5, 'RUN back with the RTRs')


def test_expedited_download_needs_the_size_indicator(bench: SimBench) -> None:
    _sim, node = add(bench)
    t = time.monotonic()
    bench.send(SDO_RX, bytes([0x22, 0x1A, 0x20, 0x00, 0x00, 0x20, 0x00, 0x00]))  # e = 1, s = 0
    reply = bench.log.wait_for(SDO_TX, since=t)[0].data
    assert reply[0] == 0x80 and struct.unpack_from('<I', reply, 4)[0] == 0x05040001
    t = time.monotonic()
    bench.send(SDO_RX, bytes([0x2B, 0x1A, 0x20, 0x00, 0x00, 0x20, 0x00, 0x00]))  # 2 bytes, size given
    assert bench.log.wait_for(SDO_TX, since=t)[0].data[0] == 0x60
    assert read(node, 0x201A, 0, 'h') == 0x2000


# ---- logic functions, references, motor --------------------------------------------------------------
def test_run_is_the_and_of_the_channels_and_starts_high_on_the_fieldbus(bench: SimBench) -> None:
    sim, node = add(bench)
    assert read(node, 0x2016, 1, 'h') == HIGH  # Tab_inp_dig_field[0] high at power-on
    assert read(node, 0x201F, 0, 'I') == 1
    assert read(node, 0x2010, 1, 'h') == HIGH and sim.run_input
    sim.set_terminal_input(0, False)  # terminal RUN low
    assert read(node, 0x2013, 0, 'H') & 1 == 0
    write(node, 0x2016, 1, 'h', HIGH)
    assert read(node, 0x2010, 1, 'h') == 0 and read(node, 0x2021, 0, 'I') & 1 == 0
    assert sim.run_channels == {'terminal': False, 'fieldbus': True, 'serial': True}
    sim.set_terminal_input(0, True)
    assert read(node, 0x2010, 1, 'h') == HIGH
    sim.set_serial_input(0, False)
    assert not sim.run_input
    sim.set_serial_input(0, True)
    write(node, 0x201F, 0, 'I', 0)  # the master drops RUN
    assert read(node, 0x2016, 1, 'h') == 0 and not sim.run_input
    # every other function is an OR: the fieldbus alone raises it
    write(node, 0x201F, 0, 'I', 1 | 1 << 3)
    assert read(node, 0x2021, 0, 'I') == 1 | 1 << 3 and read(node, 0x2010, 4, 'h') == HIGH
    sim.set_serial_input(7, True)
    assert read(node, 0x2021, 0, 'I') & 1 << 7


def test_speed_reference_needs_c52_and_reaches_its_figure(bench: SimBench) -> None:
    sim, node = add(bench, c52=0)
    write(node, 0x201A, 0, 'h', 8192)  # 50 % of n_MAX = 1500 rpm
    time.sleep(0.3)
    assert sim.speed_rpm == 0.0, 'references are ignored without C52 = 1'
    set_param(node, 'C', 52, 1)
    wait_until(lambda: abs(sim.speed_rpm - 1500.0) < 15.0, 2.0, '1500 rpm')
    assert node.sdo.upload(0x2004, 0)[:2] == b'\xe1\x00'  # element 0: direct / 2^14
    assert read(node, 0x2012, 1, 'h') == pytest.approx(8192, abs=100)  # Tab_osc[0]: 16384 = n_MAX
    assert read(node, 0x200F, 1, 'h') == pytest.approx(8192, abs=100)
    angle = sim.angle_rad
    time.sleep(0.2)
    assert sim.angle_rad - angle == pytest.approx(1500 * 2 * 3.14159 / 60 * 0.2, rel=0.5)
    write(node, 0x201F, 0, 'I', 0)  # RUN low: the motor coasts down
    wait_until(lambda: sim.speed_rpm < 1400.0, 1.0, 'coasting')
    assert not sim.running and abs(sim.torque_nm) < 1e-9


def test_speed_reference_in_electrical_pulses_per_pwm_period(bench: SimBench) -> None:
    sim, node = add(bench, speed_reference='0x201D')
    write(node, 0x201D, 0, 'h', 100)  # 100 x 8000 x 60 / (65536 x 4) = 183.1 rpm
    wait_until(lambda: abs(sim.speed_rpm - 183.1) < 2.0, 2.0, '183 rpm')
    write(node, 0x201A, 0, 'h', 16384)
    time.sleep(0.2)
    assert abs(sim.speed_rpm - 183.1) < 2.0, '0x201A is not the selected source'


def test_torque_reference_and_limit(bench: SimBench) -> None:
    sim, node = add(bench, control_mode='torque', inertia=1.0)
    write(node, 0x201B, 0, 'h', 2048)  # limit 50 % of T_nom
    write(node, 0x201C, 0, 'h', 4095)  # reference 100 % = 10 N m
    wait_until(lambda: sim.speed_rpm > 1.0, 1.0, 'acceleration')
    assert sim.torque_nm == pytest.approx(5.0, abs=0.01)
    assert read(node, 0x2012, 2, 'h') == pytest.approx(2048, abs=2)  # Tab_osc[1]: 4095 = T_nom
    assert node.sdo.upload(0x2004, 0)[2:4] == b'\x02\x00'  # element 1: percent of 4095


# ---- alarms ----------------------------------------------------------------------------------------
def test_alarm_emcy_history_and_reset(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x201A, 0, 'h', 4096)
    wait_until(lambda: sim.speed_rpm > 500, 1.0, 'running')
    t = time.monotonic()
    sim.inject_alarm(3)  # current
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes([0x00, 0x10, 0x03, 0x08, 0, 0, 0, 0])
    assert read(node, 0x2018, 0, 'H') == 0x0008 and read(node, 0x1001, 0, 'B') == 0x03
    assert read(node, 0x1003, 0, 'B') == 1 and read(node, 0x1003, 1, 'I') == 0x00081000
    assert not sim.running and sim.run_input, 'an alarm stops the drive, RUN stays'
    sim.inject_alarm(4, persistent=True)  # temperature, cause stays
    frame = bench.log.wait_for(EMCY, count=2, since=t)[1].data
    assert frame == bytes([0x00, 0x10, 0x0B, 0x18, 0, 0, 0, 0])
    assert read(node, 0x1003, 1, 'I') == 0x00181000 and read(node, 0x1003, 2, 'I') == 0x00081000
    t = time.monotonic()
    write(node, 0x201F, 0, 'I', 1 | 1 << 5)  # alarm reset function 5, rising edge
    write(node, 0x201F, 0, 'I', 1)
    frame = bench.log.wait_for(EMCY, since=t)[0].data
    assert frame == bytes([0x00, 0x00, 0x09, 0x10, 0, 0, 0, 0]), 'A3 reset, A4 left'
    assert sim.alarms == 1 << 4 and not sim.running
    sim.clear_alarm_cause(4)
    t = time.monotonic()
    write(node, 0x2016, 6, 'h', HIGH)  # the same function through Tab_inp_dig_field[5]
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes(8)
    assert read(node, 0x2018, 0, 'H') == 0 and read(node, 0x1001, 0, 'B') == 0
    wait_until(lambda: sim.running, 0.5, 'running again')


def test_disabled_alarm_sends_no_emcy_and_terminal_reset(bench: SimBench) -> None:
    sim, node = add(bench)
    set_param(node, 'P', 163, 0xFFFF & ~(1 << 10))
    assert read(node, 0x2019, 0, 'H') == 0xFBFF
    t = time.monotonic()
    sim.inject_alarm(10)
    time.sleep(0.2)
    assert not emcy_frames(bench, since=t) and read(node, 0x2018, 0, 'H') == 1 << 10
    assert read(node, 0x1001, 0, 'B') == 0x05 and read(node, 0x1003, 0, 'B') == 0
    sim.set_terminal_input(5, True)  # terminal 2 (C2 = 5): alarm reset
    assert sim.alarms == 0 and bench.log.wait_for(EMCY, since=t)[0].data == bytes(8)


# ---- parameters ------------------------------------------------------------------------------------
def test_reserved_parameter_only_off_line_with_key_p60(bench: SimBench) -> None:
    sim, node = add(bench)
    assert sim.running
    assert abort_code(lambda: set_param(node, 'P', 2, 300)) == 0x08000022  # running
    write(node, 0x201F, 0, 'I', 0)  # off-line
    assert abort_code(lambda: set_param(node, 'P', 2, 300)) == 0x08000020  # no key
    set_param(node, 'P', 60, 1)
    set_param(node, 'P', 2, 300)
    assert sim.parameter(2) == 300 and read(node, 0x200D, 3, 'h') == 300
    assert abort_code(lambda: set_param(node, 'P', 2, 1001)) == 0x06090031
    assert abort_code(lambda: set_param(node, 'P', 2, 4)) == 0x06090032
    write(node, 0x201F, 0, 'I', 1)  # a Free parameter changes on-line
    set_param(node, 'P', 1, 8190)
    assert sim.parameter(1) == 8190
    assert abort_code(lambda: set_param(node, 'P', 7, 1)) == 0x06010002  # not managed
    assert abort_code(lambda: node.sdo.download(0x1600, 1, b'\x10\x00\x0d\x20')) == 0x06040041


def test_format_tables_are_domains_read_by_segmented_upload(bench: SimBench) -> None:
    _sim, node = add(bench)
    table = node.sdo.upload(0x2001, 0)
    assert len(table) == 1600
    words = struct.unpack('<800H', table)
    assert words[4:8] == (0x1131, 0, 8190, 4095)  # P1: the appendix's example 1
    assert words[8:12] == (0x2231, 5, 1000, 10)  # P2: example 2
    assert decode_format(words[4]) == (1, 1, 3, 1)  # Free, percent of base, 3.1 digits
    assert decode_format(words[8]) == (2, 2, 3, 1)  # Reserved, proportional
    p1 = read(node, 0x200D, 2, 'h')
    assert p1 * 100 / words[7] == pytest.approx(100.0)  # 4095 / 4095 base -> 100 %
    assert read(node, 0x200D, 3, 'h') / words[11] == pytest.approx(40.0)  # 400 / 10
    connections = struct.unpack('<400H', node.sdo.upload(0x2002, 0))
    assert connections[4:8] == (0x2020, 0, 63, 1)  # C1: a Reserved connection, base 1, functions I00..I63
    extra = struct.unpack('<500H', node.sdo.upload(0x2026, 0))
    assert extra[:5] == (0x1131, 0, 8190, 4095, 4095)
    assert struct.unpack('<64H', node.sdo.upload(0x2003, 0))[:2] == (0x00E1, 0x0002)


def test_c63_saves_the_parameters_across_a_power_cycle(bench: SimBench) -> None:
    sim, node = add(bench)
    set_param(node, 'P', 3, 123)
    power_cycle(bench, sim)
    assert sim.parameter(3) == 0
    set_param(node, 'P', 3, 123)
    set_param(node, 'C', 63, 1)
    assert sim.connection(63) == 0 and sim.saved_parameter(3) == 123
    power_cycle(bench, sim)
    assert read(node, 0x200D, 4, 'h') == 123
    assert sim.parameter(162) == NODE


# ---- PDOs --------------------------------------------------------------------------------------------
def test_pdos_invalid_at_power_on_and_tpdo_type_0_at_every_sync(bench: SimBench) -> None:
    sim, node = add(bench)
    for index in (0x1400, 0x1800):
        assert read(node, index, 1, 'I') & 0x80000000
    write(node, 0x1A00, 0, 'B', 0)
    write(node, 0x1A00, 1, 'I', 0x20180010)  # alarms: unchanged from SYNC to SYNC
    write(node, 0x1A00, 2, 'I', 0x20120110)  # Tab_osc[0]
    write(node, 0x1A00, 0, 'B', 2)
    write(node, 0x1800, 2, 'B', 0)
    write(node, 0x1800, 1, 'I', TPDO1)
    start(bench, sim)
    t = time.monotonic()
    SyncLoop(bench.master, 0.01).run(5)
    frames = bench.log.wait_for(TPDO1, count=5, since=t)
    time.sleep(0.1)
    frames = bench.log.frames(TPDO1, since=t)
    assert len(frames) == 5 and len({f.data for f in frames}) == 1


def test_rpdo_types_0_to_240_apply_at_the_next_sync(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x1600, 0, 'B', 0)
    write(node, 0x1600, 1, 'I', 0x201A0010)
    write(node, 0x1600, 2, 'I', 0x201F0020)
    write(node, 0x1600, 0, 'B', 2)
    write(node, 0x1400, 2, 'B', 7)  # any of 0..240: the next SYNC
    write(node, 0x1400, 1, 'I', RPDO1)
    start(bench, sim)
    bench.send(RPDO1, struct.pack('<hI', 4096, 1))
    time.sleep(0.1)
    assert sim.value(0x201A) == 0
    bench.send(0x080, b'')
    wait_until(lambda: sim.value(0x201A) == 4096, 0.5, 'applied at SYNC')
    write(node, 0x1400, 2, 'B', 254)  # at once
    bench.send(RPDO1, struct.pack('<hI', 2048, 0))
    wait_until(lambda: sim.value(0x201A) == 2048 and not sim.run_input, 0.5, 'applied at once')


def test_rpdo_communication_has_sub_1_and_2_only(bench: SimBench) -> None:
    _sim, node = add(bench)
    assert abort_code(lambda: node.sdo.download(0x1400, 3, b'\x00\x00')) == 0x06090011
    assert abort_code(lambda: node.sdo.download(0x1400, 5, b'\x00\x00')) == 0x06090011
    assert abort_code(lambda: write(node, 0x1400, 2, 'B', 255)) == 0x06090030  # not in the list
    assert abort_code(lambda: write(node, 0x1800, 2, 'B', 245)) == 0x06090030  # reserved
    write(node, 0x1800, 3, 'H', 10)  # TPDO: all 5 managed
    write(node, 0x1800, 5, 'H', 10)


def test_tpdo_253_is_sent_on_rtr(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x1A00, 0, 'B', 0)
    write(node, 0x1A00, 1, 'I', 0x20210020)
    write(node, 0x1A00, 0, 'B', 1)
    write(node, 0x1800, 2, 'B', 253)
    write(node, 0x1800, 1, 'I', TPDO1)
    start(bench, sim)
    time.sleep(0.1)
    assert not bench.log.frames(TPDO1)
    assert rtr(bench, TPDO1) == struct.pack('<I', 1)


def test_tpdo_254_is_sent_by_the_event_timer_only(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x1A00, 0, 'B', 0)
    write(node, 0x1A00, 1, 'I', 0x201A0010)
    write(node, 0x1A00, 0, 'B', 1)
    write(node, 0x1800, 5, 'H', 100)  # ms
    write(node, 0x1800, 1, 'I', TPDO1)  # type 254 (the EDS default)
    start(bench, sim)
    time.sleep(0.25)
    t = time.monotonic()
    for value in (1234, 1235, 1236):  # changes are not events
        write(node, 0x201A, 0, 'h', value)
    time.sleep(0.6)
    frames = bench.log.frames(TPDO1)
    # every 100 ms (fewer on a busy machine)
    assert 3 <= len(frames) <= 13 and frames[-1].data == struct.pack('<h', 1236)
    assert min(b.timestamp - a.timestamp for a, b in zip(frames, frames[1:])) > 0.07, 'nothing between ticks'
    assert len(bench.log.frames(TPDO1, since=t)) <= 10


def test_restore_defaults_takes_effect_after_a_power_cycle(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x100C, 0, 'H', 100)
    write(node, 0x1010, 2, 'I', 0x65766173)  # "save"
    bench.nmt(0x82, NODE)  # reset communication loads the saved objects
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    time.sleep(0.05)
    assert read(node, 0x100C, 0, 'H') == 100
    assert abort_code(lambda: write(node, 0x1011, 2, 'I', 0x12345678)) == 0x08000020
    write(node, 0x1011, 2, 'I', 0x64616F6C)  # "load"
    bench.nmt(0x82, NODE)
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    time.sleep(0.05)
    assert read(node, 0x100C, 0, 'H') == 100, 'defaults only after a power cycle'
    power_cycle(bench, sim)
    assert read(node, 0x100C, 0, 'H') == 0


def test_array_offset_option(bench: SimBench) -> None:
    sim, node = add(bench, array_offset=0, position_element=None)
    assert read(node, 0x2016, 1, 'h') == 0  # sub 1 = element 1; element 0 (RUN) only via 0x201F
    write(node, 0x2016, 5, 'h', HIGH)  # element 5: alarm reset
    assert read(node, 0x2021, 0, 'I') & 1 << 5 and sim.run_input
    assert abort_code(lambda: write(node, 0x2016, 32, 'h', HIGH)) == 0x06090011
