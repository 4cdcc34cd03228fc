"""The AKD manual's linear IP example (§7.2.2.1, akd.md §5.7): two simulated AKDs (nodes 1 and
2) listen to one RPDO, COB-ID 0x301; axis 1 takes bytes 0..3, axis 2 bytes 4..7, each skipping
the other's with the 4-byte dummy 0x2100. Raw frames from a test-side master, answers checked
byte for byte.

Corrections to the example as printed (akd.md §12 item 5):

- axis 2's RPDO2 mapping: entry 1 is the dummy (``1601:01 = 0x21000020``) and entry 2 the
  set-point (``1601:02 = 0x60C10120``), as the comments say; the printed sub-indices are
  swapped (axis 2 would then read axis 1's bytes);
- "set COB-ID identical to axis 1" writes 0x1401:01 = 0x301 (printed against 0x1601:01);
- the interpolation period is 0x60C2 (the text says 60C1);
- the cyclic replies of TPDO2 come on 0x281 / 0x282 (printed as 0x181 / 0x182).

Step G prints ``000: 01 01`` "for all axes": that frame starts node 1 only, so node 2 gets
its own ``000: 01 02``. The RPDO2 COB-ID change on node 2 and the remappings of valid PDOs
are done in PRE-OPERATIONAL without first setting bit 31, as the manual does; the AKD
(simulated) accepts that before NMT start.

Cyclic part: one set-point frame per SYNC at 1 ms, the period written to 0x60C2; each axis
follows a ramp of its own (axis 1 +500 counts per cycle, axis 2 +1000, starting with the
manual's frame ``301: F4 01 00 00 E8 03 00 00``). A set-point latched at SYNC k is reached one
interpolation period later, so the position each axis reports at SYNC k lies between the
set-points of cycles k-2 and k-1: whatever the SYNC jitter, a drive reading the other axis'
bytes fails this. The EMCY frames of step I.4 close the test.
"""
from __future__ import annotations

import struct
import time

from akdtools import RawMaster, akd_bus, h

OPTIONS = {'lag_time_constant': 0.0}
CYCLES = 120
STEPS = {1: 500, 2: 1000}  # counts per cycle of each axis' ramp

STEP_A_AXIS1 = ['2F 01 16 00 00 00 00 00', '23 01 16 01 20 01 C1 60', '23 01 16 02 20 00 00 21',
                '2F 01 16 00 02 00 00 00']
STEP_B_AXIS2 = ['2F 01 16 00 00 00 00 00',
                '23 01 16 01 20 00 00 21',  # corrected: entry 1 = dummy (printed against sub 2)
                '23 01 16 02 20 01 C1 60',  # corrected: entry 2 = set-point (printed against sub 1)
                '2F 01 16 00 02 00 00 00',
                '23 01 14 01 01 03 00 00']  # corrected: 0x1401:01 = 0x301 (printed against 0x1601:01)
STEP_C_TPDO2 = ['2F 01 1A 00 00 00 00 00', '23 01 1A 01 20 00 63 60', '23 01 1A 02 20 00 02 10',
                '2F 01 1A 00 02 00 00 00']
STEP_E_MODE = ['2F 60 60 00 07 00 00 00']
STEP_F_PERIOD = ['2F C2 60 01 01 00 00 00', '2F C2 60 02 FD 00 00 00']  # 1 x 10^-3 s


def step_d(node: int) -> list[str]:
    return ['2F 01 14 02 01 00 00 00',  # 0x1401:02 = 1: RPDO2 taken at every SYNC
            '2F 01 18 02 01 00 00 00',  # 0x1801:02 = 1: TPDO2 sent at every SYNC
            f'23 02 18 01 {0x80 + node:02X} 03 00 80',  # TPDO3 off
            f'23 03 18 01 {0x80 + node:02X} 04 00 80']  # TPDO4 off


def configure(m: RawMaster) -> None:
    for node, mapping in ((1, STEP_A_AXIS1), (2, STEP_B_AXIS2)):
        for request in mapping + STEP_C_TPDO2 + step_d(node) + STEP_E_MODE + STEP_F_PERIOD:
            m.download(node, request)
        assert m.upload(node, 0x60C0) == h('4B C0 60 00 00 00 00 00'), 'linear interpolation (the default)'
        assert m.upload(node, 0x1401, 1) == h('43 01 14 01 01 03 00 00'), 'both listen to 0x301'


def start_and_enable(m: RawMaster) -> None:
    for node in (1, 2):
        deadline = time.monotonic() + 1.0
        while m.upload(node, 0x6061) != h('4F 61 60 00 07 00 00 00'):  # the mode is valid once 0x6061 shows it
            assert time.monotonic() < deadline
            time.sleep(0.005)
    for node in (1, 2):  # step G
        mark = m.send(0x000, bytes([0x01, node]))
        m.expect(0x180 + node, '40 02', after=mark)
    for node in (1, 2):  # step H, waiting for each reply
        for controlword, statusword in (('06 00', '31 02'), ('07 00', '33 02'), ('0F 00', '37 02'),
                                        ('1F 00', '37 12')):
            mark = m.send(0x200 + node, h(controlword))
            m.expect(0x180 + node, statusword, after=mark)


def setpoint(node: int, cycle: int) -> int:
    """Axis ``node``'s set-point in ``cycle`` (-1: where it stood)."""
    return STEPS[node] * (cycle + 1)


def test_two_axes_share_one_rpdo_with_dummy_mapping() -> None:
    with akd_bus(1, 2, options=OPTIONS) as (_bench, sniffer, m, sims):
        configure(m)
        start_and_enable(m)
        mark = sniffer.mark
        deadline = time.monotonic()
        for cycle in range(CYCLES):  # step I: set-points, then SYNC; positioning happens at the SYNC
            frame = struct.pack('<ii', setpoint(1, cycle), setpoint(2, cycle))
            if cycle == 0:
                assert frame == h('F4 01 00 00 E8 03 00 00'), "the manual's first frame"
            m.bench.send(0x301, frame)
            m.bench.send(0x080, b'')
            deadline += 0.001
            delay = deadline - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            else:
                deadline = time.monotonic()
        for node in (1, 2):
            replies = sniffer.wait(0x280 + node, mark, count=CYCLES, timeout=3.0)
            assert not sniffer.frames(0x180 + node, after=mark), 'TPDO1 (statusword, on change) stays quiet'
            for cycle, reply in enumerate(replies):  # the i-th TPDO2 answers the i-th SYNC
                position, status = struct.unpack('<iI', reply.data)
                low = setpoint(node, cycle - 2) if cycle >= 1 else 0  # setpoint(-1) = 0: where it stood
                high = setpoint(node, cycle - 1) if cycle >= 1 else 0
                assert low <= position <= high, \
                    f'axis {node}, SYNC {cycle}: position {position} outside [{low}, {high}]'
                assert status & 1 << 14, '0x1002 bit 14: power stage enabled'
            assert len(sniffer.frames(0x280 + node, after=mark)) == CYCLES, 'one TPDO2 per SYNC'

        # step I.4: an error (here: heat sink over-temperature, injected) and its reset
        mark = sniffer.mark
        sims[0].inject_fault(0x4310)
        emcy = m.expect(0x081, '10 43 09 01 00 00 00 00', after=mark)
        # the manual prints the register as 0x08 (temperature); its own §6.2.1.2 says bit 0
        # (generic error) is set for any error, which the simulated AKD does: 0x09
        assert emcy.data[2] & 0x08
        m.expect_later(0x181, '08 02', after=mark)  # Fault (0x0208), after the fault reaction
        mark = sniffer.mark
        m.send(0x201, h('80 00'))  # fault reset
        m.expect(0x081, '00 00 00 00 00 00 00 00', after=mark)
        m.expect(0x181, '40 02', after=mark)  # switch on disabled
