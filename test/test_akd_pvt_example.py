"""The AKD manual's PVT example (§7.2.2.2, akd.md §5.8), frame by frame, from a raw test-side
master against a simulated AKD (node 1), plus the buffer overflow (n704) and underflow (n705)
cases. Every SDO request is the manual's frame and every answer is checked byte for byte.

Corrections to the example as printed (akd.md §12 items 1-4):

- step 4: 0x60C0 = -2 is ``2B C0 60 00 FE FF 00 00``. The printed ``2B C0 60 00 00 00 FE FF``
  carries 0 (linear) in the two bytes a 2-byte download uses: the test sends it first, reads
  0 back, then sends the corrected frame.
- steps 1 and 9: by the mapping, 0x301 carries position (0x60C1:1) + time (0x60C1:2) and 0x401
  the velocity (0x60C1:3); the example's comments swap time and velocity.
- step 3: 0x1800:01 is **not** written, so TPDO1 (the factory statusword TPDO, event-driven)
  stays on: step 7 waits for the drive's reaction on it. The printed 0x80000281 (meant:
  0x80000181) would silence it. TPDO2..4 are disabled as printed. What else the master needs
  goes by SDO: 0x60C4:2 before every segment (step 8), and this test's own observation of the
  position (0x6063, increments) after every SYNC.

The position is compared with a cubic Hermite computed here from the points, on the drive's
own clock: the SYNC stamps the virtual bus gave the frames (the simulated drive integrates
over the same stamps). The drive runs without following lag (simulation option), so its
actual position is its trajectory.
"""
from __future__ import annotations

import struct
import time

from akdtools import RawMaster, akd_bus, h

NODE = 1
PERIOD = 0.010  # s between SYNCs
OPTIONS = {'lag_time_constant': 0.0, 'initial_position': -123456}  # not at 0: absolute positions

STEP1_PDO_MAPPING = [
    '23 01 14 01 01 03 00 80',  # 0x1401:01 = 0x80000301, RPDO2 off
    '2F 01 16 00 00 00 00 00',  # 0x1601:00 = 0
    '23 01 16 01 20 01 C1 60',  # 0x1601:01 = 0x60C10120, position
    '23 01 16 02 20 02 C1 60',  # 0x1601:02 = 0x60C10220, time
    '2F 01 16 00 02 00 00 00',  # 0x1601:00 = 2
    '23 01 14 01 01 03 00 00',  # 0x1401:01 = 0x00000301, RPDO2 on
    '23 02 14 01 01 04 00 80',  # 0x1402:01 = 0x80000401, RPDO3 off
    '2F 02 16 00 00 00 00 00',  # 0x1602:00 = 0
    '23 02 16 01 20 03 C1 60',  # 0x1602:01 = 0x60C10320, velocity
    '2F 02 16 00 01 00 00 00',  # 0x1602:00 = 1
    '23 02 14 01 01 04 00 00',  # 0x1402:01 = 0x00000401, RPDO3 on
]
STEP2_TRANSMISSION = [
    '23 01 14 02 01 00 00 00',  # 0x1401:02 = 1 (a 4-byte download to an UNSIGNED8)
    '23 02 14 02 01 00 00 00',  # 0x1402:02 = 1
]
STEP3_TPDOS_OFF = [  # 0x1800:01 left out: TPDO1 stays on (module docstring)
    '23 01 18 01 81 02 00 80',  # 0x1801:01 = 0x80000281
    '23 02 18 01 81 03 00 80',  # 0x1802:01 = 0x80000381
    '23 03 18 01 81 04 00 80',  # 0x1803:01 = 0x80000481
]
STEP5_RANGE_AND_SCALING = [
    '2B 8F 60 01 00 00 10 00',  # 0x608F:01 = 2^20 (a 2-byte download to an UNSIGNED32)
    '2F 4C 20 01 01 00 00 00',  # 0x204C:01 = 1 (a 1-byte download to an INTEGER32)
    '2F 4C 20 02 01 00 00 00',  # 0x204C:02 = 1
]
ENABLE = [('06 00', '31 02'), ('07 00', '33 02'), ('0F 00', '37 02'), ('1F 00', '37 12')]


def example_steps_1_to_7(m: RawMaster) -> None:
    """Boot-up, PDO mapping, mode, NMT start and enable, as the manual (corrected) does them."""
    m.expect(0x701, '00', after=0)  # boot-up
    for request in STEP1_PDO_MAPPING + STEP2_TRANSMISSION + STEP3_TPDOS_OFF:
        m.download(NODE, request)
    # step 4, first as printed: the value bytes a 2-byte download uses are 00 00
    m.download(NODE, '2B C0 60 00 00 00 FE FF')
    assert m.upload(NODE, 0x60C0) == h('4B C0 60 00 00 00 00 00'), 'the printed frame selects linear'
    m.download(NODE, '2B C0 60 00 FE FF 00 00')
    assert m.upload(NODE, 0x60C0) == h('4B C0 60 00 FE FF 00 00'), 'PVT (-2)'
    m.download(NODE, '2F 60 60 00 07 00 00 00')
    for request in STEP5_RANGE_AND_SCALING:
        m.download(NODE, request)
    assert m.upload(NODE, 0x608F, 1) == h('43 8F 60 01 00 00 10 00'), '2^20, as the manual means'
    assert m.upload(NODE, 0x204C, 2) == h('43 4C 20 02 01 00 00 00')
    # a mode is valid once 0x6061 shows it (the drive switches at its next cycle)
    deadline = time.monotonic() + 1.0
    while m.upload(NODE, 0x6061) != h('4F 61 60 00 07 00 00 00'):
        assert time.monotonic() < deadline, '0x6061 never showed mode 7'
        time.sleep(0.005)
    mark = m.send(0x000, h('01 01'))  # step 6: NMT start node 1
    m.expect(0x181, '40 02', after=mark)  # TPDO1 on entering OPERATIONAL: switch on disabled
    for controlword, statusword in ENABLE:  # step 7, waiting for the drive's reaction each time
        mark = m.send(0x201, h(controlword))
        m.expect(0x181, statusword, after=mark)


def push(m: RawMaster, position: int, time_ms: int, velocity: int) -> None:
    """Step 9: one PVT segment (taken at the next SYNC)."""
    m.send(0x301, struct.pack('<iI', position, time_ms))
    m.send(0x401, struct.pack('<i', velocity))


def hermite(p0: float, v0: float, p1: float, v1: float, duration: float, t: float) -> tuple[float, float]:
    """Position and velocity of the cubic Hermite at t (0 <= t <= duration)."""
    s = t / duration
    position = ((2 * s ** 3 - 3 * s ** 2 + 1) * p0 + (s ** 3 - 2 * s ** 2 + s) * duration * v0
                + (-2 * s ** 3 + 3 * s ** 2) * p1 + (s ** 3 - s ** 2) * duration * v1)
    velocity = ((6 * s ** 2 - 6 * s) * (p0 - p1) / duration + (3 * s ** 2 - 4 * s + 1) * v0
                + (3 * s ** 2 - 2 * s) * v1)
    return position, velocity


def reference(start: float, points: list[tuple[int, int, int]], t: float) -> tuple[float, float]:
    """The trajectory through ``points`` (position, ms, velocity) from ``start`` at rest, at t s."""
    p, v, t0 = start, 0.0, 0.0
    for position, time_ms, velocity in points:
        duration = time_ms / 1000.0
        if t <= t0 + duration:
            return hermite(p, v, position, velocity, duration, t - t0)
        p, v, t0 = position, velocity, t0 + duration
    return p, 0.0


class Pacer:
    """Absolute deadlines every PERIOD s."""

    def __init__(self) -> None:
        self.deadline = time.monotonic()

    def wait(self) -> None:
        self.deadline += PERIOD
        delay = self.deadline - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            self.deadline = time.monotonic()


def test_pvt_example_frame_by_frame() -> None:
    with akd_bus(NODE, options=OPTIONS) as (_bench, sniffer, m, _sims):
        example_steps_1_to_7(m)
        start = m.read_i32(NODE, 0x6063)
        points = [(start + 30000, 60, 800000), (start + 80000, 60, 600000), (start + 100000, 60, 0)]
        end = (start + 100000, 0, 0)  # time 0 ends the motion
        to_send = points + [end]
        reached_at = [0.06, 0.12, 0.18, 0.18]  # s after the first SYNC; the end point goes with the last

        mark = sniffer.mark
        pacer = Pacer()
        free_seen, samples = [], []
        first_stamp = previous_stamp = None
        irregular = jittered = False
        for cycle in range(26):
            free = m.read_u32(NODE, 0x60C4, 2)  # step 8: the buffer, before every segment
            if previous_stamp is not None:
                t = previous_stamp - first_stamp
                pending = sum(1 for i in range(min(cycle, len(to_send))) if t < reached_at[i] - 1e-9)
                # (not once a SYNC came late: on a busy machine the drive's segment clock and the
                # SYNC stamps then differ by up to that lateness)
                if not jittered and all(abs(t - r) > 0.001 for r in reached_at):
                    assert free == 9 - pending, f'0x60C4:2 at t={t * 1000:.1f} ms: {free}, expected {9 - pending}'
            if cycle < len(to_send):
                free_seen.append(free)
                assert free > 0, 'never send a segment into a full buffer'
                push(m, *to_send[cycle])
            sync = m.sync()
            if first_stamp is None:
                first_stamp = sync.stamp
            elif sync.stamp - previous_stamp > 0.040:
                irregular = True  # a stalled VM: the drive's clock may have run on its own for a moment
            if previous_stamp is not None and sync.stamp - previous_stamp > 1.5 * PERIOD:
                jittered = True
            previous_stamp = sync.stamp
            samples.append((sync.stamp - first_stamp, m.read_i32(NODE, 0x6063), irregular))
            pacer.wait()

        assert free_seen == [9, 8, 7, 6], 'the buffer fills as points queue (the running one included)'
        moving = 0
        for t, position, after_stall in samples:
            expected, velocity = reference(start, points, t)
            tolerance = 3 + abs(velocity) * (0.005 if after_stall else 0.0001)
            assert abs(position - expected) <= tolerance, \
                f'at {t * 1000:.1f} ms: position {position}, Hermite {expected:.1f} (tolerance {tolerance:.0f})'
            moving += 0 < t < 0.18
        assert moving >= 10, 'enough samples inside the motion'
        # linear interpolation between the points would miss by thousands of counts
        assert abs(reference(start, points, 0.03)[0] - (start + 15000)) > 5000

        assert samples[-1][1] == start + 100000, 'stopped at the last point'
        assert m.read_u32(NODE, 0x60C4, 2) == 9, 'buffer empty again'
        m.expect_later(0x181, '37 16', after=mark)  # target reached (bit 10) once the motion ended
        assert not sniffer.frames(0x81, after=mark), 'no EMCY: neither overflow nor underflow'
        assert m.upload(NODE, 0x6041)[4:6] == h('37 16')


def test_pvt_overflow_on_the_tenth_point() -> None:
    """Nine places are usable; a tenth point while 0x60C4:2 reads 0 is dropped with n704."""
    with akd_bus(NODE, options=OPTIONS) as (_bench, sniffer, m, _sims):
        example_steps_1_to_7(m)
        start = m.read_i32(NODE, 0x6063)
        free_seen = []
        for i in range(9):
            free_seen.append(m.read_u32(NODE, 0x60C4, 2))
            push(m, start + 1000 * (i + 1), 2000 if i == 0 else 100, 0)  # a slow first segment
            m.sync()
        assert free_seen == [9, 8, 7, 6, 5, 4, 3, 2, 1]
        assert m.read_u32(NODE, 0x60C4, 2) == 0, 'full'

        mark = sniffer.mark
        push(m, start + 50000, 100, 0)  # the tenth, ignoring step 8 on purpose
        m.sync()
        m.expect(0x81, '84 85 00 01 00 00 00 00', after=mark)  # n704; no fault in the register
        m.expect(0x181, 'B7 12', after=mark)  # statusword: warning bit 7
        assert m.read_u32(NODE, 0x60C4, 2) == 0, 'the point was dropped'
        assert m.upload(NODE, 0x1003, 1) == h('43 03 10 01 84 85 00 00')
        assert m.upload(NODE, 0x1001) == h('4F 01 10 00 00 00 00 00'), 'a warning is not an error'

        again = sniffer.mark
        push(m, start + 60000, 100, 0)  # an eleventh: dropped too, no second EMCY for the same warning
        m.sync()
        time.sleep(0.05)
        assert m.read_u32(NODE, 0x60C4, 2) == 0
        assert not sniffer.frames(0x81, after=again)

        mark = sniffer.mark
        m.download(NODE, '2F C4 60 06 00 00 00 00')  # 0x60C4:6 = 0: clear the buffer
        m.expect(0x181, '37 12', after=mark)  # the warning goes with the buffer
        assert m.read_u32(NODE, 0x60C4, 2) == 9
        m.download(NODE, '2F C4 60 06 01 00 00 00')  # accept points again


def test_pvt_underflow_holds_the_position() -> None:
    """The master stops feeding mid-motion: n705, and the axis brakes to a standstill on the
    controlled-stop ramp (0x3440:1 CS.DEC) and stays enabled there."""
    with akd_bus(NODE, options=OPTIONS) as (_bench, sniffer, m, _sims):
        example_steps_1_to_7(m)
        start = m.read_i32(NODE, 0x6063)
        deceleration = m.read_u32(NODE, 0x3440, 1)
        last_velocity = 1_200_000
        points = [(start + 40000, 50, 1_000_000), (start + 100000, 50, last_velocity)]
        mark = sniffer.mark
        pacer = Pacer()
        for cycle in range(20):
            if cycle < len(points):
                assert m.read_u32(NODE, 0x60C4, 2) > 0
                push(m, *points[cycle])
            m.sync()
            pacer.wait()
        emcy = m.expect(0x81, '85 85 00 01 00 00 00 00', after=mark)  # n705
        warning = m.expect(0x181, 'B7 12', after=mark)
        assert warning.index > emcy.index
        stop = start + 100000 + last_velocity ** 2 / (2 * deceleration)  # braking from the last point's velocity
        held = [m.read_i32(NODE, 0x6063)]
        for _ in range(3):
            m.sync()
            held.append(m.read_i32(NODE, 0x6063))
        assert all(abs(p - stop) <= 2 for p in held), f'held at {held}, expected {stop:.0f}'
        assert m.upload(NODE, 0x6041)[4:6] == h('B7 12'), 'still Operation Enabled, warning, ip active'
        assert m.upload(NODE, 0x1003, 1) == h('43 03 10 01 85 85 00 00')

        # feeding again starts a new motion from where the axis stands; the warning clears
        mark = sniffer.mark
        assert m.read_u32(NODE, 0x60C4, 2) == 9
        push(m, start + 110000, 50, 0)
        m.sync()
        m.expect(0x181, '37 12', after=mark)
        push(m, start + 110000, 0, 0)
        for _ in range(8):
            m.sync()
            pacer.wait()
        assert m.read_i32(NODE, 0x6063) == start + 110000
        m.expect_later(0x181, '37 16', after=mark)
        assert not [f for f in sniffer.frames(0x81, after=mark)], 'no EMCY for a fed motion'
