"""The simulated SERVOSTAR 400/600 (family ``servostar``), checked through CAN frames from a
test-side master (canopen RemoteNode, raw frames) on a private virtual channel, against the facts
in shared/drives/servostar-400-600.md (section numbers in brackets).

Node 1 unless said otherwise; the object dictionary is the shipped servostar.eds. Timing bounds
are generous (noisy 2-core CI).
"""
from __future__ import annotations

import struct
import time
from collections.abc import Iterator

import canopen
import pytest

from drive_bridge.sim import SimServostar, simulator_for
from drive_bridge.sim.testing import SimBench, SyncLoop, wait_until
from servostartools import (
    EMCY,
    GUARD,
    NODE,
    RPDO2,
    SYNC,
    TPDO2,
    abort_of,
    add,
    emcys,
    enable,
    raw_sdo,
    read,
    set_mode,
    statusword,
    wait_emcy,
    write,
)


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


def restart_with(bench: SimBench, sim: SimServostar, node: canopen.RemoteNode, **parameters: int) -> None:
    """Object-channel parameters (name=value: PTBASE, VLIM, ...) written, saved, cold-started."""
    names = {'PTBASE': (0x35D5, 'b'), 'PRBASE': (0x35D1, 'b'), 'VLIM': (0x3622, 'i'), 'DRVCNFG': (0x3672, 'i'),
             'DECSTOP': (0x3525, 'h')}
    for name, value in parameters.items():
        index, fmt = names[name]
        write(node, index, 1, fmt, value)
    write(node, 0x35EB, 1, 'I', 0)  # SAVE
    start = time.monotonic()
    write(node, 0x3632, 1, 'I', 0)  # COLDSTART
    bench.log.wait_for(EMCY, since=start)
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 1.0, 'boot after COLDSTART')


# -- boot-up, NMT, SDO ----------------------------------------------------------------------------------
def test_registered_as_the_servostar_simulator() -> None:
    assert simulator_for('servostar') is SimServostar


def test_bootup_is_an_emcy_with_eight_zero_bytes_and_no_0x700_frame(bench: SimBench) -> None:
    sim, node = add(bench)
    assert [f.data for f in bench.log.frames(EMCY)] == [bytes(8)]
    time.sleep(0.2)
    assert not bench.log.frames(GUARD), 'no CiA 301 boot-up frame [2.3]'
    assert sim.nmt_state == 'PRE-OPERATIONAL'
    assert statusword(node) == 0x0040  # Switch On Disabled, bit 4 = 0: DC link present [9.2]
    assert abort_of(node, 0x1017, 0) == 0x06020000  # no heartbeat
    assert abort_of(node, 0x1016, 1) == 0x06020000


@pytest.mark.parametrize(('bit_option', 'drvcnfg', 'length'), [
    (0, 0x1, 0), (0, 0x4, 8),  # §2.6: bit 0 = 0-byte telegram (the default reading)
    (2, 0x4, 0), (2, 0x1, 8),  # §6.1.1: bit 2
])
def test_bootup_emcy_length_follows_the_drvcnfg_bit(bench: SimBench, bit_option: int, drvcnfg: int,
                                                     length: int) -> None:
    add(bench, bootup_length_bit=bit_option, drvcnfg=drvcnfg)
    assert [len(f.data) for f in bench.log.frames(EMCY)] == [length]
    assert all(b == 0 for f in bench.log.frames(EMCY) for b in f.data)


def test_nmt_reset_node_is_a_cold_start(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x35D5, 1, 'b', 8)  # PTBASE, not saved
    start = time.monotonic()
    bench.nmt(0x81, NODE)
    assert bench.log.wait_for(EMCY, since=start)[0].data == bytes(8)  # boot-up EMCY again
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 1.0, 'booted')
    assert read(node, 0x35D5, 1, 'b') == 4, 'RAM values are discarded'
    write(node, 0x35D5, 1, 'b', 8)
    write(node, 0x35EB, 1, 'I', 0)  # SAVE
    start = time.monotonic()
    bench.nmt(0x81, NODE)
    bench.log.wait_for(EMCY, since=start)
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 1.0, 'booted')
    assert read(node, 0x35D5, 1, 'b') == 8, 'saved values come back'
    assert sim.axis_star.period == pytest.approx(0.002)  # PTBASE 8 = 2 ms, effective after the restart


def test_sdo_is_expedited_only(bench: SimBench) -> None:
    _sim, node = add(bench)
    segmented = raw_sdo(bench, bytes([0x21, 0x08, 0x10, 0x00, 0x04, 0, 0, 0]))  # initiate segmented download
    assert segmented[0] == 0x80 and struct.unpack_from('<I', segmented, 4)[0] == 0x05040001
    block = raw_sdo(bench, bytes([0xC6, 0x40, 0x60, 0x00, 0x02, 0, 0, 0]))  # initiate block download
    assert block[0] == 0x80 and struct.unpack_from('<I', block, 4)[0] == 0x05040001
    block_up = raw_sdo(bench, bytes([0xA4, 0x41, 0x60, 0x00, 0x7F, 0, 0, 0]))
    assert block_up[0] == 0x80 and struct.unpack_from('<I', block_up, 4)[0] == 0x05040001
    assert node.sdo.upload(0x1008, 0) == b'SD06'  # 4 characters: expedited
    assert raw_sdo(bench, bytes([0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0]))[:6] == bytes([0x4B, 0x41, 0x60, 0, 0x40, 0])


def test_expedited_downloads_of_another_size_are_fitted(bench: SimBench) -> None:
    """§6.1.2 writes the controlword with a 4-byte frame, §6.1.4 an INTEGER32 with a 2-byte one."""
    _sim, node = add(bench)
    assert raw_sdo(bench, bytes([0x23, 0x40, 0x60, 0x00, 0x07, 0, 0, 0]))[0] == 0x60
    assert raw_sdo(bench, bytes([0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0]))[4:6] == bytes([0x23, 0x00])  # Switched On
    assert raw_sdo(bench, bytes([0x2B, 0x24, 0x20, 0x03, 0x10, 0x27, 0, 0]))[0] == 0x60
    assert read(node, 0x2024, 3, 'i') == 10000
    write(node, 0x3672, 1, 'i', 0x4)  # DRVCNFG bit 2: object length check
    answer = raw_sdo(bench, bytes([0x2B, 0x24, 0x20, 0x03, 0x10, 0x27, 0, 0]))
    assert answer[0] == 0x80 and struct.unpack_from('<I', answer, 4)[0] == 0x06070010


def test_modes_of_operation_is_write_only(bench: SimBench) -> None:
    sim, node = add(bench)
    assert abort_of(node, 0x6060, 0) == 0x06010001
    assert read(node, 0x6061, 0, 'b') == -7  # OPMODE 8 (position) saved: comes up in homing [4.6]
    set_mode(sim, node, -6)
    for unsupported in (2, 4, 7, 0):
        assert abort_of(node, 0x6060, 0, 'b', unsupported) == 0x06090030  # no vl, tq, ip
    assert read(node, 0x6061, 0, 'b') == -6


def test_a_mode_changes_only_at_standstill(bench: SimBench) -> None:
    sim, node = add(bench)
    set_mode(sim, node, -2)  # digital speed
    enable(sim, node)
    write(node, 0x2060, 0, 'i', 419430)  # 3000 rpm [2.6]
    wait_until(lambda: abs(sim.axis_star.v - 419430 * 125) < 1e6, 2.0, 'turning at 3000 rpm (2^20 x 50 counts/s)')
    assert int.from_bytes(node.sdo.upload(0x2070, 2), 'little', signed=True) == pytest.approx(419430, rel=0.02)
    write(node, 0x6060, 0, 'b', 3)
    time.sleep(0.1)
    assert read(node, 0x6061, 0, 'b') == -2, 'no mode change while the motor turns'
    write(node, 0x2060, 0, 'i', 0)
    wait_until(lambda: read(node, 0x6061, 0, 'b') == 3, 3.0, 'pv at standstill')
    assert abs(sim.axis_star.v) < 1e3


# -- state machine, statusword --------------------------------------------------------------------------
def test_state_machine_as_the_manual_shows_it(bench: SimBench) -> None:
    sim, node = add(bench, hardware_enable=False)
    start = time.monotonic()
    write(node, 0x6040, 0, 'H', 0x0007)
    assert statusword(node) == 0x0021, 'transition 3 needs the hardware enable'
    frames = wait_emcy(bench, start, 0x7181)
    assert frames[0][3] == 5  # category 5: operating error
    sim.set_hardware_enable(True)
    write(node, 0x6040, 0, 'H', 0x0007)
    assert statusword(node) == 0x0023  # §6.1.2
    write(node, 0x6040, 0, 'H', 0x000F)
    assert statusword(node) & 0x6F == 0x27
    assert not statusword(node) & 0x0200, 'bit 9 (remote) is not supported'
    assert read(node, 0x1002, 0, 'I') & 1 << 30  # output stage enabled
    sim.set_dc_link(False)
    assert statusword(node) & 0x0010, 'bit 4 inverted: 1 = no DC link'
    assert statusword(node) & 0x4F == 0x40  # the stage went off: Switch On Disabled


def test_quick_stop_brakes_keeps_the_stage_enabled_and_clears_the_setpoint(bench: SimBench) -> None:
    sim, node = add(bench)
    set_mode(sim, node, -2)
    enable(sim, node)
    write(node, 0x2060, 0, 'i', 100000)
    wait_until(lambda: abs(sim.axis_star.v) > 1e6, 2.0, 'turning')
    write(node, 0x6040, 0, 'H', 0x000B)  # quick stop
    wait_until(lambda: abs(sim.axis_star.v) < 1e3, 2.0, 'stopped on DECSTOP')
    assert statusword(node) & 0x6F == 0x07  # Quick Stop Active
    assert read(node, 0x1002, 0, 'I') & 1 << 30
    assert read(node, 0x2060, 0, 'i') == 0, 'quick stop clears the setpoints [4.3]'
    write(node, 0x6040, 0, 'H', 0x000F)  # transition 16
    assert statusword(node) & 0x6F == 0x27


# -- node guarding, life guarding ---------------------------------------------------------------------------
def rtr(bench: SimBench) -> bytes:
    start = time.monotonic()
    bench.master.send_message(GUARD, b'', remote=True)
    return bench.log.wait_for(GUARD, since=start, timeout=0.5)[0].data


def test_node_guarding_replies_toggle(bench: SimBench) -> None:
    _sim, _node = add(bench)
    assert [rtr(bench), rtr(bench), rtr(bench)] == [b'\x7f', b'\xff', b'\x7f']
    bench.nmt(0x01, NODE)
    time.sleep(0.05)
    assert rtr(bench) == b'\x85'


def test_life_guarding_runs_only_while_the_output_stage_is_enabled(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x100C, 0, 'H', 50)
    write(node, 0x100D, 0, 'B', 2)  # life time 100 ms
    rtr(bench)  # armed
    start = time.monotonic()
    time.sleep(0.4)
    assert not emcys(bench, start), 'Switch On Disabled: no response monitoring'
    assert not read(node, 0x1002, 0, 'I') & 1 << 3
    set_mode(sim, node, -2)
    enable(sim, node)
    write(node, 0x2060, 0, 'i', 100000)
    wait_until(lambda: abs(sim.axis_star.v) > 1e6, 2.0, 'turning')
    start = time.monotonic()
    frames = wait_emcy(bench, start, 0x8181, timeout=1.0)  # no RTR for the life time
    error, follow = frames[0], frames[1]
    assert error[:2] == b'\x81\x81' and error[3] == 2 and error[4:] == bytes(4)  # category 2
    assert follow[:2] == b'\x00\x00' and follow[2] == error[2] != 0
    assert read(node, 0x1002, 0, 'I') & (1 << 3 | 1 << 31) == 1 << 3 | 1 << 31  # n04, error pending
    assert statusword(node) & 0x0080  # warning
    wait_until(lambda: abs(sim.axis_star.v) < 1e3, 2.0, 'braked on the quick-stop ramp')
    assert statusword(node) & 0x6F == 0x27, 'no Fault state: still Operation Enabled'
    rtr(bench)
    time.sleep(0.05)
    assert sim.axis_star.braking == 'error', 'RTRs again do not clear n04'
    start = time.monotonic()
    write(node, 0x6040, 0, 'H', 0x080F)  # bit 11: acknowledge
    reset = wait_emcy_reset(bench, start)
    assert reset[:3] == b'\x00\x00\x00'
    assert not read(node, 0x1002, 0, 'I') & (1 << 3 | 1 << 31)
    write(node, 0x2060, 0, 'i', 100000)
    wait_until(lambda: abs(sim.axis_star.v) > 1e6, 2.0, 'motion again')


def wait_emcy_reset(bench: SimBench, since: float) -> bytes:
    frames = bench.log.wait_for(EMCY, since=since, timeout=1.0)
    return frames[-1].data


# -- PDOs ---------------------------------------------------------------------------------------------------
def test_pdo_library_selection_and_the_free_pdo_rule(bench: SimBench) -> None:
    sim, node = add(bench)
    assert sim.selected_pdos() == {'rpdo': [1, 21, 0, 0], 'tpdo': [1, 21, 0, 0]}
    assert read(node, 0x1600, 1, 'I') == 0x60400010
    assert abort_of(node, 0x1600, 1, 'I', 0x60600008) == 0x06010002, 'read-only while 0x2600 = 1'
    assert abort_of(node, 0x1600, 0, 'B', 0) == 0x06010002
    write(node, 0x2A00, 0, 'B', 23)  # extended status [9.3 step 9]
    assert [read(node, 0x1A00, 0, 'B'), read(node, 0x1A00, 1, 'I'), read(node, 0x1A00, 2, 'I')] == \
        [2, 0x60410010, 0x10020020]
    assert abort_of(node, 0x2600, 0, 'B', 2) == 0x06090030  # reserved number
    write(node, 0x2600, 0, 'B', 37)  # free PDO [9.3 steps 1-3]
    write(node, 0x1600, 0, 'I', 0)
    write(node, 0x1600, 1, 'I', 0x20220420)
    assert read(node, 0x1600, 0, 'B') == 1, 'the drive counts the entries itself'
    write(node, 0x1600, 2, 'I', 0x60600008)
    assert sim.mapping(False, 1) == [0x20220420, 0x60600008]
    assert abort_of(node, 0x1600, 3, 'I', 0x607A0020) == 0x06040042  # 72 bits
    assert abort_of(node, 0x1600, 3, 'I', 0x20700320) == 0x06040041  # read-only object in an RPDO
    assert abort_of(node, 0x1600, 3, 'I', 0x35D50108) == 0x06040041  # object channel: not mappable


def test_no_event_timer_and_per_pdo_transmission_types(bench: SimBench) -> None:
    _sim, node = add(bench)
    for index in (0x1400, 0x1800, 0x1803):
        assert abort_of(node, index, 5, 'H', 100) == 0x06090011
        assert read(node, index, 0, 'B') == 4
    write(node, 0x2601, 0, 'B', 33)
    assert read(node, 0x1401, 2, 'B') == 1, 'RPDO 33 cannot run asynchronously'
    assert abort_of(node, 0x1401, 2, 'B', 255) == 0x06090030
    write(node, 0x2601, 0, 'B', 35)
    assert read(node, 0x1401, 2, 'B') == 255
    assert abort_of(node, 0x1401, 2, 'B', 1) == 0x06090030  # RPDO 35: 255 only
    assert abort_of(node, 0x1801, 2, 'B', 1) == 0x06090030  # TPDO 21: 255 only
    write(node, 0x2A01, 0, 'B', 33)
    assert abort_of(node, 0x1801, 2, 'B', 255) == 0x06090030  # TPDO 33: SYNC only
    write(node, 0x1801, 2, 'B', 3)


def test_free_tpdo_with_24_bit_entries_on_sync(bench: SimBench) -> None:
    """§6.1.3 steps 10-15: incremental position 32 bit + speed 24 bit + mode display 8 bit."""
    sim, node = add(bench)
    write(node, 0x2A01, 0, 'B', 37)
    write(node, 0x1A01, 0, 'I', 0)
    for sub, entry in enumerate((0x20700320, 0x20700218, 0x60610008), start=1):
        write(node, 0x1A01, sub, 'I', entry)
    write(node, 0x1801, 2, 'B', 1)
    bench.nmt(0x01, NODE)
    time.sleep(0.05)
    start = time.monotonic()
    bench.send(SYNC, b'')
    frame = bench.log.wait_for(TPDO2, since=start)[0].data
    assert len(frame) == 8
    position, speed, mode = struct.unpack('<i', frame[:4])[0], int.from_bytes(frame[4:7], 'little', signed=True), \
        struct.unpack('<b', frame[7:])[0]
    assert (position, speed, mode) == (sim.axis_star.position, 0, -7)


def test_pdo_configuration_is_lost_at_power_on_unless_stored(bench: SimBench) -> None:
    sim, node = add(bench)
    write(node, 0x2A00, 0, 'B', 23)
    assert abort_of(node, 0x1010, 2, 'I', 0x65766173) == 0x08000020, 'needs DRVCNFG bit 3'

    def power_cycle() -> None:
        sim.power_off()
        start = time.monotonic()
        sim.power_on()
        bench.log.wait_for(EMCY, since=start)
        wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 1.0, 'booted')

    power_cycle()
    assert read(node, 0x2A00, 0, 'B') == 1
    write(node, 0x3672, 1, 'i', 0x8)
    write(node, 0x35EB, 1, 'I', 0)  # SAVE (DRVCNFG)
    write(node, 0x2A00, 0, 'B', 23)
    write(node, 0x1800, 2, 'B', 1)
    write(node, 0x1010, 2, 'I', 0x65766173)  # "save"
    write(node, 0x2A00, 0, 'B', 1)  # changed after the store: lost
    power_cycle()
    assert read(node, 0x2A00, 0, 'B') == 23
    assert read(node, 0x1A00, 2, 'I') == 0x10020020
    assert read(node, 0x1800, 2, 'B') == 1


def test_ascii_terminal_over_pdo_21(bench: SimBench) -> None:
    sim, node = add(bench)
    bench.nmt(0x01, NODE)
    time.sleep(0.05)
    start = time.monotonic()
    bench.send(RPDO2, b'PTBASE\r\n')
    frames = bench.log.wait_for(TPDO2, since=start, timeout=1.0)
    answer = b''.join(f.data for f in frames).rstrip(b'\0')
    assert answer.startswith(b'4\r\n')
    bench.send(RPDO2, b'VLIM 100')
    bench.send(RPDO2, b'0\r\n\0\0\0\0\0')
    wait_until(lambda: read(node, 0x3622, 1, 'i') == 1000, 1.0, 'VLIM written over ASCII')
    assert ('VLIM 1000', '') in sim.ascii_log


# -- trajectory mode 0xFA ---------------------------------------------------------------------------------
def trajectory_setup(bench: SimBench, sim: SimServostar, node: canopen.RemoteNode, node_id: int = NODE,
                     cob: int | None = None, half: int = 0) -> None:
    """§5.4: RPDO 2 <- PDO 33 and TPDO 2 <- free PDO (position 2070:03 + speed 2070:02) on every SYNC,
    mode 0xFA, NMT start, enable."""
    write(node, 0x2601, 0, 'B', 33)
    if cob is not None:
        write(node, 0x1401, 1, 'I', cob)
    write(node, 0x2721, 0, 'B', half)
    write(node, 0x2A01, 0, 'B', 37)
    write(node, 0x1A01, 0, 'I', 0)
    write(node, 0x1A01, 1, 'I', 0x20700320)
    write(node, 0x1A01, 2, 'I', 0x20700218)
    write(node, 0x1401, 2, 'B', 1)
    write(node, 0x1801, 2, 'B', 1)
    set_mode(sim, node, -6)
    bench.nmt(0x01, node_id)
    enable(sim, node)


def feedback(bench: SimBench, since: float, node_id: int = NODE) -> list[tuple[int, int]]:
    """(position 2^20/rev, speed bits) of every TPDO 2 since ``since``."""
    return [(struct.unpack_from('<i', f.data)[0], int.from_bytes(f.data[4:7], 'little', signed=True))
            for f in bench.log.frames(0x280 + node_id, since=since)]


def run_ramp(bench: SimBench, period: float, cycles: int, step: int, first: int = 0,
             cob: int = RPDO2) -> None:
    loop = SyncLoop(bench.master, period)
    loop.run(cycles, before=lambda i: bench.send(cob, struct.pack('<ii', first + step * (i + 1), 0)))


def test_trajectory_follows_one_setpoint_per_sync(bench: SimBench) -> None:
    sim, node = add(bench)
    restart_with(bench, sim, node, PTBASE=40)  # 10 ms, saved and cold-started [5.1]
    trajectory_setup(bench, sim, node)
    start = time.monotonic()
    run_ramp(bench, 0.010, 60, 5000)
    axis = sim.axis_star
    wait_until(lambda: abs(axis.position - 300000) < 2000, 1.0, 'the last setpoint reached')
    samples = feedback(bench, start)
    assert len(samples) >= 55
    mid = samples[20:50]
    assert all(b[0] > a[0] for a, b in zip(mid, mid[1:])), 'moving on every cycle'
    speeds = [speed for _position, speed in mid]
    expected = 5000 / 0.010 / 125  # speed bits for 5000 counts per 10 ms
    assert sum(speeds) / len(speeds) == pytest.approx(expected, rel=0.2)
    # most SYNC intervals match PTBASE (the test's own SYNC loop: a busy machine delays some)
    assert axis.timing_mismatches < 0.5 * len(axis.sync_intervals)
    assert not sim.errors['cat2']
    assert axis.clamped_steps == 0


def test_trajectory_sync_interval_other_than_ptbase_makes_the_profile_dip(bench: SimBench) -> None:
    sim, node = add(bench)  # PTBASE 4 = 1 ms, SYNC every 10 ms
    trajectory_setup(bench, sim, node)
    start = time.monotonic()
    run_ramp(bench, 0.010, 40, 5000)
    axis = sim.axis_star
    assert axis.timing_mismatches >= 0.8 * len(axis.sync_intervals) > 0
    speeds = [speed for _position, speed in feedback(bench, start)[10:38]]
    expected = 5000 / 0.010 / 125
    assert sum(abs(s) for s in speeds) / len(speeds) < 0.3 * expected, 'at each SYNC the axis stands: it dips'
    assert not sim.errors['cat2'], "option trajectory_timing 'dip': no error"


def test_trajectory_timing_error_option(bench: SimBench) -> None:
    sim, node = add(bench, trajectory_timing='error')
    trajectory_setup(bench, sim, node)
    start = time.monotonic()
    run_ramp(bench, 0.010, 10, 500)
    frames = wait_emcy(bench, start, 0x8682)
    assert frames[0][3] == 2
    assert sim.axis_star.braking == 'error'


def test_trajectory_step_beyond_vlim_and_following_error_beyond_pemax(bench: SimBench) -> None:
    sim, node = add(bench)
    restart_with(bench, sim, node, PTBASE=40, VLIM=100)  # 10 ms; 100 rpm = 17476 counts per period
    write(node, 0x2020, 3, 'i', 10 ** 8)  # PEMAX out of the way
    trajectory_setup(bench, sim, node)
    axis = sim.axis_star
    start = time.monotonic()
    run_ramp(bench, 0.010, 10, 30000)  # each step 30000 > VLIM x PTBASE
    assert axis.clamped_steps >= 5
    assert abs(axis.v) <= axis.vlim() * 1.05, 'the demand is limited to VLIM'
    assert not sim.errors['cat2']
    write(node, 0x2020, 3, 'i', 0x40000)  # PEMAX back to its default (user units = counts)
    start = time.monotonic()
    run_ramp(bench, 0.010, 10, 60000, first=300000)  # the command runs away from the demand
    frames = wait_emcy(bench, start, 0x8611)
    error, follow = frames[0], frames[1]
    assert error[:2] == b'\x11\x86' and error[3] == 2 and follow[:2] == b'\x00\x00' and follow[2] == error[2]
    assert axis.braking == 'error'
    wait_until(lambda: abs(axis.v) < 1e3, 2.0, 'emergency ramp to standstill')
    status = read(node, 0x1002, 0, 'I')
    assert status & (1 << 2 | 1 << 31) == 1 << 2 | 1 << 31  # n03, error pending
    assert statusword(node) & 0x6F == 0x27, 'no Fault state'
    start = time.monotonic()
    write(node, 0x6040, 0, 'H', 0x080F)  # bit 11
    assert wait_emcy_reset(bench, start)[:3] == b'\x00\x00\x00'
    assert axis.braking is None and not sim.errors['cat2']


def test_trajectory_step_check_error_option(bench: SimBench) -> None:
    sim, node = add(bench, trajectory_step_check='error')
    write(node, 0x2020, 3, 'i', 10 ** 8)
    trajectory_setup(bench, sim, node)
    start = time.monotonic()
    run_ramp(bench, 0.010, 3, 200000)  # 1 ms PTBASE at 3000 rpm: 52429 counts per period
    wait_emcy(bench, start, 0x8611)


def test_pdo_33_feeds_two_drives_from_one_frame(bench: SimBench) -> None:
    """§5.4: both drives' RPDO 2 on COB-ID 0x301, 0x2721 picks the half (0 and 4 as printed)."""
    sim1, node1 = add(bench, 1)
    sim2, node2 = add(bench, 2)
    trajectory_setup(bench, sim1, node1, 1, half=0)
    trajectory_setup(bench, sim2, node2, 2, cob=0x301, half=4)
    bench.send(0x301, bytes.fromhex('F4010000E8030000'))  # 500, 1000 [5.4 step 9]
    bench.send(SYNC, b'')
    wait_until(lambda: sim1.value(0x2022, 4) == 500 and sim2.value(0x2022, 4) == 1000, 1.0, 'both setpoints')
    wait_until(lambda: abs(sim1.axis_star.position - 500) < 5 and abs(sim2.axis_star.position - 1000) < 5, 1.0,
               'both positioned')
    assert abort_of(node1, 0x2721, 0, 'B', 1) == 0x06090030, "option 'offset': 0 or 4"


def test_pdo_33_half_by_index_option(bench: SimBench) -> None:
    sim, node = add(bench, pdo33_half_select='index')
    trajectory_setup(bench, sim, node, half=1)
    bench.send(RPDO2, struct.pack('<ii', 111, 222))
    bench.send(SYNC, b'')
    wait_until(lambda: sim.value(0x2022, 4) == 222, 1.0, 'the upper half')


# -- errors without a Fault state -----------------------------------------------------------------------------
def test_category_1_fault_shows_no_fault_pattern_and_bit_7_restarts_the_drive(bench: SimBench) -> None:
    sim, node = add(bench)
    enable(sim, node)
    start = time.monotonic()
    sim.inject_fault(0x7303)  # feedback (resolver), F04, category 1
    frames = wait_emcy(bench, start, 0x7303)
    error, follow = frames[0], frames[1]
    assert error[:2] == b'\x03\x73' and error[3] == 1 and error[4:] == bytes(4)
    # the follow-up's byte 3 is 00h: the frame §6.2.1.1 prints after a category 1 fault
    # (``081: 00 00 08 00 00 00 00 00``); the option emcy_follow_up_category makes it the category
    assert follow == bytes([0, 0, error[2], 0, 0, 0, 0, 0]) and error[2] == 0x80  # 7303h: no class, bit 7
    sw = statusword(node)
    assert sw & 0x4F != 0x08, 'no Fault state pattern'
    assert sw & 0x4F == 0x40  # the output stage went off: Switch On Disabled
    assert read(node, 0x1002, 0, 'I') & 1 << 31
    assert read(node, 0x2070, 0x16, 'I') == 1 << 3  # ERRCODE: F04
    assert read(node, 0x1003, 0, 'B') == 1 and read(node, 0x1003, 1, 'I') == 0x7303
    assert abort_of(node, 0x1003, 2) == 0x06090011, '0x1003 keeps one entry'
    write(node, 0x6040, 0, 'H', 0x000F)
    assert statusword(node) & 0x6F == 0x21, 'no enable while the fault is pending'
    start = time.monotonic()
    write(node, 0x6040, 0, 'H', 0x0080)  # bit 7: reset = restart
    assert bench.log.wait_for(EMCY, since=start)[0].data == bytes(8), 'the boot-up EMCY again'
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 1.0, 'booted')
    assert not read(node, 0x1002, 0, 'I') & 1 << 31
    assert statusword(node) == 0x0040


def test_persistent_fault_comes_back_after_the_restart(bench: SimBench) -> None:
    sim, node = add(bench)
    sim.inject_fault(0x4310, persistent=True)
    boots = sim.boot_messages
    write(node, 0x6040, 0, 'H', 0x0080)
    # after the restart's boot-up (frames since a stamp could be the pair sent before the restart)
    wait_until(lambda: sim.boot_messages > boots and sim.errors['cat1'] == [0x4310], 2.0, '0x4310 after the restart')
    sim.clear_fault_cause()
    write(node, 0x6040, 0, 'H', 0x0000)
    start = time.monotonic()
    write(node, 0x6040, 0, 'H', 0x0080)
    bench.log.wait_for(EMCY, since=start)
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 1.0, 'booted')
    # the restart clears them (waited for: a busy machine may run the restart after this test's next line)
    wait_until(lambda: sim.errors == {'cat1': [], 'cat2': []}, 2.0, 'the errors cleared by the restart')


def test_category_5_error_is_the_emcy_pair_only(bench: SimBench) -> None:
    sim, node = add(bench)
    enable(sim, node)
    start = time.monotonic()
    sim.inject_fault(0x8282)  # wrong mode setting
    frames = wait_emcy(bench, start, 0x8282)
    assert frames[0][3] == 5 and frames[1][:3] == b'\x00\x00\x00'
    assert statusword(node) & 0x6F == 0x27


# -- other modes -----------------------------------------------------------------------------------------------
def test_motion_task_0_by_rpdo_34_and_rpdo_35(bench: SimBench) -> None:
    """Mode 0xFF: RPDO 34 (position, weighted speed, type) starts the direct task 0; RPDO 35
    starts a task by number [2.6, 9.5]; statusword bit 8 toggles at every completed task."""
    sim, node = add(bench)
    write(node, 0x2601, 0, 'B', 34)
    set_mode(sim, node, -1)
    bench.nmt(0x01, NODE)
    enable(sim, node)
    before = statusword(node) & 0x0100
    bench.send(RPDO2, struct.pack('<ihH', 200000, 1000, 0))  # absolute 200000, 1000 x 4000 counts/s
    wait_until(lambda: sim.axis_star.task_active, 1.0, 'task started')
    assert read(node, 0x1002, 0, 'I') & 1 << 16  # motion task active
    wait_until(lambda: bool(statusword(node) & 0x0400) and not sim.axis_star.task_active, 2.0, 'target reached')
    assert abs(sim.axis_star.position - 200000) < 50
    assert statusword(node) & 0x0100 != before, 'bit 8 toggled'
    write(node, 0x2601, 0, 'B', 35)
    write(node, 0x2022, 1, 'i', -50000)
    write(node, 0x2022, 3, 'H', 1)  # relative
    bench.send(RPDO2, struct.pack('<H', 0))  # start task 0
    wait_until(lambda: abs(sim.axis_star.position - 150000) < 50 and not sim.axis_star.task_active, 2.0,
               'relative task done')
    start = time.monotonic()
    bench.send(RPDO2, struct.pack('<H', 7))  # no stored task 7 in the simulation
    assert wait_emcy(bench, start, 0x8681)[0][3] == 5


def test_profile_position_in_user_units(bench: SimBench) -> None:
    """pp with 0x6093 = 2^20 / 10000 (10000 user units per revolution) and ramp times in ms."""
    sim, node = add(bench)
    set_mode(sim, node, 1)
    enable(sim, node)
    write(node, 0x6081, 0, 'I', 1000)  # 1000 x 4000 counts/s (0x6094 = 0/0: increments per 250 us)
    write(node, 0x6083, 0, 'I', 50)
    write(node, 0x6084, 0, 'I', 50)
    write(node, 0x607A, 0, 'i', 5000)  # half a revolution
    toggle = statusword(node) & 0x0100
    write(node, 0x6040, 0, 'H', 0x001F)
    wait_until(lambda: bool(statusword(node) & 0x1000), 1.0, 'setpoint acknowledge')
    write(node, 0x6040, 0, 'H', 0x000F)
    wait_until(lambda: bool(statusword(node) & 0x0400), 3.0, 'target reached')
    assert read(node, 0x6064, 0, 'i') == pytest.approx(5000, abs=2)
    assert read(node, 0x6063, 0, 'i') == pytest.approx(2 ** 19, abs=200)
    assert statusword(node) & 0x0100 != toggle


def test_manufacturer_homing_sets_the_reference_offset(bench: SimBench) -> None:
    sim, node = add(bench)  # comes up in 0xF9 (OPMODE 8)
    write(node, 0x2024, 1, 'B', 0)  # type 0: reference at the actual position
    write(node, 0x2024, 6, 'i', 12345)
    enable(sim, node)
    assert not read(node, 0x1002, 0, 'I') & 1 << 17
    write(node, 0x6040, 0, 'H', 0x001F)
    wait_until(lambda: bool(read(node, 0x1002, 0, 'I') & 1 << 17), 1.0, 'reference point set')
    assert read(node, 0x2070, 3, 'i') == pytest.approx(12345, abs=2)
