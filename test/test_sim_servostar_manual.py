"""The simulated SERVOSTAR 400/600 against the frames its manual prints (German manual 12/2009,
``shared/drives/manuals/servostar-400-600-canopen-manual-de.txt``; section numbers are the
manual's, the facts document's in brackets): a raw tester on the bus, frames in and out.

- EMCY: the error register bits and the follow-up frame of §6.1.10 and §6.2.1.1 [9.9, 5.4];
- the status byte 2080h:09 (TRJSTAT byte 2 = 1002h bits 16..23) while a homing of the CiA 402
  mode 6 and a profile-position move run and when they end, as §6.1.6 prints it [9.6];
- the same byte around a motion task of mode FFh (§6.1.5), referenced first as §6.1.4 asks of a
  linear axis [9.4, 9.5];
- 1002h bit 16 (motion task active) and bit 17 (reference set) around a homing [3.5, 4.7].
"""
from __future__ import annotations

import struct
import time
from collections.abc import Iterator

import pytest

from akdtools import h
from drive_bridge.sim.testing import SimBench, wait_until
from servostartools import EMCY, NODE, add, emcys, enable, raw_sdo, read, set_mode, wait_emcy, write

TPDO1, RPDO1, RPDO2 = 0x180 + NODE, 0x200 + NODE, 0x300 + NODE
TASK_ACTIVE, REFERENCE_SET, HOME_POSITION, IN_POSITION = 0x01, 0x02, 0x04, 0x08  # 2080h:09 = 1002h >> 16


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


def exchange(bench: SimBench, request: str, response: str) -> None:
    """One SDO request as the manual prints it, and its printed response, byte for byte."""
    assert raw_sdo(bench, h(request)) == h(response), request


# -- EMCY: error register and follow-up (§3.4.4, §6.1.10, §6.2.1.1) ------------------------------------
def test_motor_temperature_fault_sends_the_pair_of_6_2_1_1(bench: SimBench) -> None:
    """§6.2.1.1 prints ``081: 10 43 08 01 00 00 00 00`` then ``081: 00 00 08 00 00 00 00 00``:
    error register 08h (temperature, no generic bit 0), category 01 in byte 3, the follow-up's
    byte 3 zero."""
    sim, _node = add(bench)
    start = time.monotonic()
    sim.inject_fault(0x4310)  # motor temperature, F06
    frames = wait_emcy(bench, start, 0x4310)
    assert frames[:2] == [h('10 43 08 01 00 00 00 00'), h('00 00 08 00 00 00 00 00')]


def test_follow_up_reports_every_pending_error_as_6_1_10(bench: SimBench) -> None:
    """§6.1.10 (the resolver plug pulled) prints the follow-up ``081: 00 00 88 00 00 00 00``: the
    motor temperature bit 3 and bit 7, read here as the feedback fault 7303h pending as well
    (a code of no CiA 301 class sets bit 7, manufacturer specific)."""
    sim, _node = add(bench)
    start = time.monotonic()
    sim.inject_fault(0x4310)
    sim.inject_fault(0x7303)  # feedback unit (resolver), F04
    frames = wait_emcy(bench, start, 0x7303)
    assert frames[2:4] == [h('03 73 88 01 00 00 00 00'), h('00 00 88 00 00 00 00 00')]
    assert read(_node, 0x1001, 0, 'B') == 0x88


@pytest.mark.parametrize('options, pair', [
    ({'emcy_error_register': 'cia301'}, ('10 43 09 01 00 00 00 00', '00 00 09 00 00 00 00 00')),
    ({'emcy_follow_up_category': True}, ('10 43 08 01 00 00 00 00', '00 00 08 01 00 00 00 00')),
])
def test_emcy_readings_kept_as_options(bench: SimBench, options: dict[str, object], pair: tuple[str, str]) -> None:
    """The other readings: CiA 301's generic bit 0 beside the class bit; the category repeated in
    the follow-up's byte 3 (the sentence of §3.4.4.2)."""
    sim, _node = add(bench, **options)
    start = time.monotonic()
    sim.inject_fault(0x4310)
    assert wait_emcy(bench, start, 0x4310)[:2] == [h(pair[0]), h(pair[1])]


def test_category_2_acknowledge_sends_the_error_free_frame(bench: SimBench) -> None:
    """§3.4.4.1 transitions 2 and 4: the reset frame has code 0000h, the remaining register and a
    zero manufacturer field; 8611h (following error, CiA 402 profile class) sets bit 5."""
    sim, node = add(bench)
    enable(sim, node)
    start = time.monotonic()
    sim.inject_fault(0x8611)
    assert wait_emcy(bench, start, 0x8611)[:2] == [h('11 86 20 02 00 00 00 00'), h('00 00 20 00 00 00 00 00')]
    start = time.monotonic()
    write(node, 0x6040, 0, 'H', 0x080F)  # bit 11: acknowledge (category 2)
    assert bench.log.wait_for(EMCY, since=start)[0].data == bytes(8)


# -- the status byte 2080h:09 in §6.1.6 (homing mode 6, then profile position) ---------------------------
def status_frames(bench: SimBench, since: float) -> list[tuple[int, int]]:
    """(statusword, status byte) of every TPDO 1 (6041h + 2080h:09) since ``since``."""
    return [struct.unpack('<HB', f.data) for f in bench.log.frames(TPDO1, since=since) if len(f.data) == 3]


def test_homing_mode_6_and_profile_position_as_6_1_6(bench: SimBench) -> None:
    """§6.1.6: TPDO 1 = free PDO 37 with the statusword and 2080h:09, RPDO 2 = free PDO 38 with
    607Ah / 6081h; homing method 12 in mode 6 ends with byte 2 bit 0 = 0 (homing finished), bit
    1 = 1 (reference set), bit 3 = 1 (in position); a pp move then reads ``181: 27 15 03`` at
    the set-point acknowledge (03h: task active, reference set) and ``27 05 0A`` at the target
    (0Ah: reference set, in position)."""
    sim, node = add(bench, initial_position=2 ** 24)  # 16 revolutions from the home switch at 0
    exchange(bench, '2F 01 26 00 26 00 00 00', '60 01 26 00 00 00 00 00')  # 2nd RPDO <- PDO 38
    exchange(bench, '23 01 16 00 00 00 00 00', '60 01 16 00 00 00 00 00')
    exchange(bench, '23 01 16 01 20 00 7A 60', '60 01 16 01 00 00 00 00')  # target_position
    exchange(bench, '23 01 16 02 20 00 81 60', '60 01 16 02 00 00 00 00')  # profile_velocity
    exchange(bench, '2F 00 2A 00 25 00 00 00', '60 00 2A 00 00 00 00 00')  # 1st TPDO <- PDO 37
    exchange(bench, '23 00 1A 00 00 00 00 00', '60 00 1A 00 00 00 00 00')
    exchange(bench, '23 00 1A 01 10 00 41 60', '60 00 1A 01 00 00 00 00')  # statusword
    exchange(bench, '23 00 1A 02 08 09 80 20', '60 00 1A 02 00 00 00 00')  # TRJSTAT byte 3 (2080h:09)
    bench.nmt(0x01, NODE)
    exchange(bench, '23 93 60 01 00 00 10 00', '60 93 60 01 00 00 00 00')  # 2^20 increments
    exchange(bench, '23 93 60 02 A0 8C 00 00', '60 93 60 02 00 00 00 00')  # 36000 user units
    # the in-position window (PEINPOS, µm = counts here) narrower than the 500 units (14563 counts) of the
    # move, so that the target is not "actual position = home position" (bit 18), as 0Ah shows
    write(node, 0x2020, 2, 'i', 4000)
    exchange(bench, '2B 40 60 00 0F 00 00 00', '60 40 60 00 00 00 00 00')  # operation enable
    wait_until(lambda: sim.axis_star.state.name == 'OPERATION_ENABLED', 1.0, 'Operation Enabled')
    exchange(bench, '2F 60 60 00 06 00 00 00', '60 60 60 00 00 00 00 00')  # homing mode
    wait_until(lambda: read(node, 0x6061, 0, 'b') == 6, 2.0, '0x6061 = 6')  # valid once 6061h shows it
    exchange(bench, '2F 98 60 00 0C 00 00 00', '60 98 60 00 00 00 00 00')  # method 12
    exchange(bench, '23 99 60 01 40 19 01 00', '60 99 60 01 00 00 00 00')  # 72000 units/s
    start = time.monotonic()
    exchange(bench, '2B 40 60 00 1F 00 00 00', '60 40 60 00 00 00 00 00')  # start homing
    wait_until(lambda: any(byte & TASK_ACTIVE for _sw, byte in status_frames(bench, start)), 2.0, 'homing runs')
    running = [byte for _sw, byte in status_frames(bench, start) if byte & TASK_ACTIVE]
    assert all(not byte & (REFERENCE_SET | IN_POSITION) for byte in running), running

    def homed() -> bool:
        frames = status_frames(bench, start)
        return bool(frames) and frames[-1][1] & (TASK_ACTIVE | REFERENCE_SET | IN_POSITION) == 0x0A
    wait_until(homed, 5.0, 'homing finished, reference set, in position')
    assert read(node, 0x1002, 0, 'I') & 0x00030000 == 0x00020000  # bit 17 set, bit 16 clear
    assert read(node, 0x2080, 9, 'B') & 0x0B == 0x0A

    bench.send(RPDO1, h('0F 00'))  # end homing
    exchange(bench, '23 83 60 00 32 00 00 00', '60 83 60 00 00 00 00 00')  # 50 ms
    exchange(bench, '23 84 60 00 32 00 00 00', '60 84 60 00 00 00 00 00')  # 50 ms
    exchange(bench, '2F 60 60 00 01 00 00 00', '60 60 60 00 00 00 00 00')  # profile position
    wait_until(lambda: read(node, 0x6061, 0, 'b') == 1, 2.0, '0x6061 = 1')
    bench.send(RPDO2, h('F4 01 00 00 E8 03 00 00'))  # 607Ah = 500, 6081h = 1000
    time.sleep(0.02)
    start = time.monotonic()
    bench.send(RPDO1, h('1F 00'))  # new set-point
    wait_until(lambda: any(sw & 0x1000 for sw, _b in status_frames(bench, start)), 1.0, 'set-point acknowledge')
    acknowledged = next((sw, byte) for sw, byte in status_frames(bench, start) if sw & 0x1000)
    assert acknowledged[0] & 0x00FF == 0x27 and acknowledged[1] == 0x03, acknowledged  # 181: 27 15 03
    bench.send(RPDO1, h('0F 00'))

    def reached() -> bool:
        frames = status_frames(bench, start)
        return bool(frames) and frames[-1][0] & 0x1400 == 0x0400 and frames[-1][1] == 0x0A
    wait_until(reached, 2.0, '181: 27 05 0A')
    sw, byte = status_frames(bench, start)[-1]
    assert sw & 0x04FF == 0x0427 and byte == 0x0A
    assert abs(read(node, 0x6064, 0, 'i') - 500) <= 1


def test_motion_task_status_byte_while_it_runs_and_at_the_target(bench: SimBench) -> None:
    """§6.1.5 (mode FFh, 2nd RPDO <- PDO 35 ``2F 01 26 00 23 ...``, ``301: 00 00`` starts task 0)
    with the TPDO 1 of §6.1.6 (statusword + 2080h:09). A linear axis is referenced before it
    positions (§6.1.4): here by the manufacturer homing F9h, type 0 (reference point at the actual
    position). The status byte then reads as §6.1.6 prints it: ``03h`` (task active, reference
    set) while the task runs and ``0Ah`` (reference set, in position) at the target [9.4-9.6]."""
    sim, node = add(bench)
    exchange(bench, '2F 01 26 00 23 00 00 00', '60 01 26 00 00 00 00 00')  # 2nd RPDO <- PDO 35
    exchange(bench, '2F 00 2A 00 25 00 00 00', '60 00 2A 00 00 00 00 00')  # 1st TPDO <- PDO 37
    exchange(bench, '23 00 1A 00 00 00 00 00', '60 00 1A 00 00 00 00 00')
    exchange(bench, '23 00 1A 01 10 00 41 60', '60 00 1A 01 00 00 00 00')
    exchange(bench, '23 00 1A 02 08 09 80 20', '60 00 1A 02 00 00 00 00')
    bench.nmt(0x01, NODE)
    enable(sim, node)
    exchange(bench, '2F 60 60 00 F9 00 00 00', '60 60 60 00 00 00 00 00')  # §6.1.4: mode homing F9h
    wait_until(lambda: read(node, 0x6061, 0, 'b') == -7, 2.0, '0x6061 = F9h')
    exchange(bench, '2F 24 20 01 00 00 00 00', '60 24 20 01 00 00 00 00')  # type 0: here
    exchange(bench, '2B 40 60 00 1F 00 00 00', '60 40 60 00 00 00 00 00')  # start
    wait_until(lambda: read(node, 0x1002, 0, 'I') & 0x00030000 == 0x00020000, 1.0, 'reference set')
    exchange(bench, '2B 40 60 00 0F 00 00 00', '60 40 60 00 00 00 00 00')
    exchange(bench, '2F 60 60 00 FF 00 00 00', '60 60 60 00 00 00 00 00')  # §6.1.5: position mode
    wait_until(lambda: read(node, 0x6061, 0, 'b') == -1, 2.0, '0x6061 = FFh')
    write(node, 0x2022, 1, 'i', 2 ** 22)  # 4 revolutions, absolute
    write(node, 0x2022, 2, 'H', 2000)  # x 4000 counts/s: about 7.6 rev/s
    start = time.monotonic()
    bench.send(RPDO2, h('00 00'))  # start task 0
    wait_until(lambda: any(byte & TASK_ACTIVE for _sw, byte in status_frames(bench, start)), 1.0, 'task runs')
    running = [byte for _sw, byte in status_frames(bench, start) if byte & TASK_ACTIVE]
    assert set(running) == {0x03}, running  # 03h: task active, reference set
    wait_until(lambda: (frames := status_frames(bench, start)) != [] and frames[-1][1] & 0x09 == IN_POSITION, 3.0,
               'target reached')
    assert status_frames(bench, start)[-1][1] == 0x0A  # 0Ah: reference set, in position
    assert read(node, 0x1002, 0, 'I') & 0x000B0000 == 0x000A0000
    assert abs(sim.axis_star.position - 2 ** 22) < 50


def test_manufacturer_homing_sets_the_reference_at_its_end(bench: SimBench) -> None:
    """Mode F9h, §6.1.4 [9.4]: 1002h bit 16 (task active) while the homing runs, bit 17
    (reference set) rises as it ends and bit 16 falls."""
    sim, node = add(bench, initial_position=2 ** 22)  # 4 revolutions from the switch: VREF 0 is VLIM / 10
    set_mode(sim, node, -7)
    write(node, 0x2024, 1, 'B', 1)  # homing to the reference switch
    enable(sim, node)
    write(node, 0x6040, 0, 'H', 0x001F)
    status = read(node, 0x1002, 0, 'I')
    assert status & 0x00030000 == 0x00010000, hex(status)  # running, no reference yet
    wait_until(lambda: read(node, 0x1002, 0, 'I') & 0x00030000 == 0x00020000, 5.0, 'reference set')
    assert len(emcys(bench, 0.0)) == 1, 'no EMCY besides the boot-up'
