"""CiA 301 behaviour of the simulated slaves, checked only through CAN frames from a
test-side master (canopen RemoteNode, raw frames) on a private virtual channel."""
from __future__ import annotations

import statistics
import struct
import time
from collections.abc import Iterator

import canopen
import pytest

from drive_bridge.cia402.statemachine import State, state_from_statusword
from drive_bridge.sim import SimulatedSlave
from drive_bridge.sim.testing import Frame, SimBench, SyncLoop, wait_until
from timingtools import BUSY_SLACK

NODE = 5
HEARTBEAT = 0x700 + NODE
TPDO1, TPDO2, TPDO3 = 0x180 + NODE, 0x280 + NODE, 0x380 + NODE
EMCY = 0x80 + NODE


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


def start(bench: SimBench, sim: SimulatedSlave) -> None:
    bench.nmt(0x01, NODE)
    wait_until(lambda: sim.nmt_state == 'OPERATIONAL', 0.5, 'OPERATIONAL')


def test_boot_up_frame_then_heartbeat_at_the_producer_period(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE, power_on=False)
    assert sim.nmt_state == 'OFF'
    t0 = time.monotonic()
    sim.power_on()
    boot = bench.log.wait_for(HEARTBEAT, since=t0)
    assert boot[0].data == b'\x00'
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    time.sleep(0.1)
    assert len(bench.log.frames(HEARTBEAT)) == 1, '0x1017 = 0 in the EDS: no heartbeat'
    node.sdo[0x1017].raw = 20
    t1 = time.monotonic()
    time.sleep(0.5)
    beats = bench.log.frames(HEARTBEAT, since=t1)
    took = time.monotonic() - t1
    assert beats and all(f.data == b'\x7f' for f in beats)
    intervals = [b.timestamp - a.timestamp for a, b in zip(beats, beats[1:])]
    assert 5 <= len(beats) <= took / 0.020 + 2  # never faster than 20 ms (a busy machine: slower)
    assert statistics.median(intervals) == pytest.approx(0.020, abs=0.004)
    start(bench, sim)
    t2 = time.monotonic()
    assert bench.log.wait_for(HEARTBEAT, since=t2)[0].data == b'\x05'


def test_sdo_identity_and_typed_objects(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE, options={'serial_number': 0x12345678})
    assert node.sdo[0x1000].raw == 0x00020192
    assert [node.sdo[0x1018][s].raw for s in (1, 2, 3, 4)] == [0, 0x402, 0x00010000, 0x12345678]
    assert node.sdo[0x1008].raw == 'drive_bridge simulated CiA 402 drive (1 axis)'  # segmented upload
    assert node.sdo[0x1014].raw == 0x80 + NODE
    for index, value in ((0x607A, -123456), (0x6081, 3_000_000_000), (0x605A, -1), (0x6098, -3),
                         (0x6071, -250), (0x60C2, None)):
        if value is None:
            continue
        node.sdo[index].raw = value
        assert node.sdo[index].raw == value
    assert node.sdo.upload(0x6041, 0) == struct.pack('<H', sim.axis().statusword)
    node.sdo[0x60C2][1].raw = 2
    node.sdo[0x60C2][2].raw = -3
    assert sim.axis().interpolation_period() == pytest.approx(0.002)


@pytest.mark.parametrize('access, code', [
    (lambda n: n.sdo.download(0x6041, 0, b'\x00\x00'), 0x06010002),  # read-only
    (lambda n: n.sdo.download(0x1018, 1, b'\x00\x00\x00\x00'), 0x06010002),
    (lambda n: n.sdo.download(0x1008, 0, b'other name'), 0x06010002),  # const
    (lambda n: n.sdo.upload(0x2000, 0), 0x06020000),  # no such object
    (lambda n: n.sdo.upload(0x1018, 9), 0x06090011),  # no such sub-index (record)
    (lambda n: n.sdo.upload(0x1003, 20), 0x06090011),  # ... of an array (canopen would invent it)
    (lambda n: n.sdo.upload(0x6040, 1), 0x06090011),  # ... of a plain variable
    (lambda n: n.sdo.upload(0x60C4, 6), 0x06010001),  # write-only
    (lambda n: n.sdo.download(0x6040, 0, b'\x00\x00\x00\x00'), 0x06070010),  # length
    (lambda n: n.sdo.download(0x6060, 0, b'\x02'), 0x06090030),  # velocity mode not in 0x6502
    (lambda n: n.sdo.download(0x6060, 0, b'\xff'), 0x06090030),  # manufacturer mode
    (lambda n: n.sdo.download(0x60C0, 0, b'\xff\xff'), 0x06090030),  # only linear interpolation
    (lambda n: n.sdo.download(0x1003, 0, b'\x01'), 0x06090030),  # history: only 0 may be written
    (lambda n: n.sdo.download(0x1A00, 0, b'\x00'), 0x08000022),  # mapping of a valid TPDO
    (lambda n: n.sdo.download(0x1600, 1, struct.pack('<I', 0x60400010)), 0x08000022),
    (lambda n: n.sdo.download(0x1400, 1, struct.pack('<I', 0x206)), 0x06090030),  # COB-ID while valid
    (lambda n: n.sdo.download(0x1800, 2, b'\xf5'), 0x06090030),  # reserved transmission type
    (lambda n: n.sdo.download(0x1005, 0, struct.pack('<I', 0x40000080)), 0x06090030),  # SYNC producer
])
def test_sdo_abort_codes(bench: SimBench, access, code: int) -> None:
    _sim, node = bench.add_drive(NODE)
    with pytest.raises(canopen.SdoAbortedError) as err:
        access(node)
    assert err.value.code == code


def test_pdo_mapping_rules_abort_codes(bench: SimBench) -> None:
    _sim, node = bench.add_drive(NODE)
    sdo = node.sdo

    def aborts(index: int, sub: int, value: int, fmt: str = '<I') -> int:
        with pytest.raises(canopen.SdoAbortedError) as err:
            sdo.download(index, sub, struct.pack(fmt, value))
        return err.value.code

    sdo[0x1800][1].raw = 0x80000000 | TPDO1  # disable TPDO1: its mapping is still sub0 = 3
    assert aborts(0x1A00, 1, 0x60640020) == 0x08000022  # entries only while sub0 = 0
    sdo[0x1A00][0].raw = 0
    assert aborts(0x1A00, 1, 0x60650020) == 0x06040041  # following error window: not mappable
    assert aborts(0x1A00, 1, 0x20000010) == 0x06020000  # no such object
    assert aborts(0x1A00, 1, 0x60410020) == 0x06040043  # length differs from the object
    assert aborts(0x1A00, 1, 0x00050008) == 0x06040041  # dummy mapping not supported
    for sub, entry in ((1, 0x60640020), (2, 0x606C0020), (3, 0x60410010)):
        sdo[0x1A00][sub].raw = entry
    assert aborts(0x1A00, 0, 3, '<B') == 0x06040042  # 80 bits
    assert aborts(0x1A00, 0, 9, '<B') == 0x06090031  # more entries than the record has
    sdo[0x1A00][0].raw = 2
    sdo[0x1800][3].raw = 10  # inhibit time: allowed while the PDO is invalid
    sdo[0x1800][1].raw = TPDO1
    assert aborts(0x1800, 3, 20, '<H') == 0x06090030  # ... not while valid
    sdo[0x1401][1].raw = 0x80000000 | 0x300 | NODE
    sdo[0x1601][0].raw = 0
    assert aborts(0x1601, 1, 0x60410010) == 0x06040041  # an RPDO cannot write the statusword
    assert aborts(0x1401, 1, 0x581) == 0x06090030  # restricted CAN-ID (SDO)


def test_injected_sdo_abort_and_consumer_duplicate(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    sim.abort_sdo_on(0x6041, 0, 0x08000021)
    with pytest.raises(canopen.SdoAbortedError) as err:
        node.sdo.upload(0x6041, 0)
    assert err.value.code == 0x08000021
    sim.abort_sdo_on(0x6041, 0, None)
    node.sdo.upload(0x6041, 0)
    node.sdo[0x1016][1].raw = 127 << 16 | 300
    with pytest.raises(canopen.SdoAbortedError) as err:
        node.sdo[0x1016][2].raw = 127 << 16 | 500
    assert err.value.code == 0x06040043
    node.sdo[0x1016][2].raw = 126 << 16 | 500


def test_nmt_gates_pdos_and_sdo(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    sync = SyncLoop(bench.master, 0.004)
    sync.run(5)
    time.sleep(0.02)
    assert not bench.log.frames(TPDO1), 'no PDO in PRE-OPERATIONAL'
    assert sim.received_sync_count == 5
    start(bench, sim)
    t = time.monotonic()
    sync.run(5)
    bench.log.wait_for(TPDO2, 5, since=t)
    assert len(bench.log.frames(TPDO1, since=t)) == 5
    bench.nmt(0x02, NODE)
    wait_until(lambda: sim.nmt_state == 'STOPPED', 0.5)
    t = time.monotonic()
    sync.run(5)
    time.sleep(0.02)
    assert not bench.log.frames(TPDO1, since=t), 'no PDO in STOPPED'
    with pytest.raises(canopen.SdoCommunicationError):
        node.sdo.upload(0x1000, 0)  # no SDO in STOPPED
    bench.nmt(0x80, 0)  # broadcast pre-operational
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    assert node.sdo[0x1000].raw == 0x00020192
    bench.nmt(0x01, NODE + 1)  # for another node
    time.sleep(0.02)
    assert sim.nmt_state == 'PRE-OPERATIONAL'


def test_reset_node_restores_defaults_and_boots_again(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x6081].raw = 1234
    node.sdo[0x1800][2].raw = 5
    node.sdo[0x6040].raw = 0x06
    assert state_from_statusword(node.sdo[0x6041].raw) is State.READY_TO_SWITCH_ON
    t = time.monotonic()
    bench.nmt(0x82, NODE)  # reset communication: 0x1000..0x1FFF only
    assert bench.log.wait_for(HEARTBEAT, since=t)[0].data == b'\x00'
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    assert node.sdo[0x1800][2].raw == 1
    assert node.sdo[0x6081].raw == 1234
    assert state_from_statusword(node.sdo[0x6041].raw) is State.READY_TO_SWITCH_ON
    t = time.monotonic()
    bench.nmt(0x81, 0)  # reset node (broadcast): everything back
    assert bench.log.wait_for(HEARTBEAT, since=t)[0].data == b'\x00'
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    assert node.sdo[0x6081].raw == 50000
    assert state_from_statusword(node.sdo[0x6041].raw) is State.SWITCH_ON_DISABLED


def test_boot_delay_keeps_the_node_silent_until_boot_up(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    sim.set_boot_delay(0.15)
    t = time.monotonic()
    bench.nmt(0x81, NODE)
    time.sleep(0.03)
    assert sim.nmt_state == 'INITIALISING'
    with pytest.raises(canopen.SdoCommunicationError):
        node.sdo.upload(0x1000, 0)
    boot = bench.log.wait_for(HEARTBEAT, since=t, timeout=1.0)[0]
    assert boot.timestamp - t >= 0.14
    assert node.sdo[0x1000].raw == 0x00020192


def test_tpdo_after_every_sync_and_every_third_sync(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    start(bench, sim)
    sync = SyncLoop(bench.master, 0.005)
    t = time.monotonic()
    counts: list[int] = []

    def after(i: int) -> None:  # exactly one TPDO1 per SYNC, sent right after it
        bench.log.wait_for(TPDO1, i + 1, since=t, timeout=0.2)
        counts.append(len(bench.log.frames(TPDO1, since=t)))

    sync.run(6, after=after)
    assert counts == [1, 2, 3, 4, 5, 6]
    node.sdo[0x1800][2].raw = 3
    t = time.monotonic()
    counts.clear()

    def after3(i: int) -> None:  # frames can come late, never before their SYNC: wait for the exact count
        expected = (i + 1) // 3
        try:
            wait_until(lambda: len(bench.log.frames(TPDO1, since=t)) == expected, 0.2)
        finally:
            counts.append(len(bench.log.frames(TPDO1, since=t)))

    sync.run(9, after=after3)
    time.sleep(0.02)
    assert counts == [0, 0, 1, 1, 1, 2, 2, 2, 3]
    assert len(bench.log.frames(TPDO1, since=t)) == 3
    assert len(bench.log.frames(TPDO2, since=t)) == 9  # TPDO2 still type 1


def test_event_driven_tpdo_on_change_and_by_event_timer(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x1800][2].raw = 255
    node.sdo[0x1800][5].raw = 20  # event timer, ms
    t = time.monotonic()
    start(bench, sim)
    time.sleep(0.3)
    frames = bench.log.frames(TPDO1, since=t)
    took = time.monotonic() - t
    assert 4 <= len(frames) <= took / 0.020 + 3, 'sent on entering OPERATIONAL, then every 20 ms without SYNC'
    assert statistics.median(b.timestamp - a.timestamp for a, b in zip(frames, frames[1:])) \
        == pytest.approx(0.020, abs=0.005)
    node.sdo[0x1800][5].raw = 1000  # a 1 s timer from its next frame on: "at once" is told from it on a busy machine
    time.sleep(0.1)
    t = time.monotonic()
    node.sdo.download(0x6040, 0, struct.pack('<H', 0x06))
    def changed() -> list[Frame]:  # a timer frame may go out between t and the write: skip it
        return [f for f in bench.log.frames(TPDO1, since=t)
                if state_from_statusword(struct.unpack_from('<H', f.data)[0]) is State.READY_TO_SWITCH_ON]
    wait_until(lambda: bool(changed()), 1.5, 'TPDO1 with the new statusword')
    assert changed()[0].timestamp - t < 0.5, 'a change is sent at once, not at the next timer (1 s)'


def test_inhibit_time_spaces_event_driven_tpdos(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x1800][1].raw = 0x80000000 | TPDO1
    node.sdo[0x1800][2].raw = 254
    node.sdo[0x1800][3].raw = 2000  # 200 ms: long beside a busy machine's stalls
    node.sdo[0x1800][1].raw = TPDO1
    start(bench, sim)
    first = bench.log.wait_for(TPDO1)[0].timestamp
    for cw in (0x06, 0x07):  # two changes inside the inhibit time: one frame, the latest value
        node.sdo.download(0x6040, 0, struct.pack('<H', cw))
    frames = bench.log.wait_for(TPDO1, 2, timeout=1.0)
    assert frames[1].timestamp - first >= 0.195
    assert state_from_statusword(struct.unpack_from('<H', frames[1].data)[0]) is State.SWITCHED_ON
    time.sleep(0.25)
    assert len(bench.log.frames(TPDO1)) == 2
    t = time.monotonic()  # the inhibit time is over: the next change goes out at once, not 200 ms on
    node.sdo.download(0x6040, 0, struct.pack('<H', 0x06))
    assert bench.log.wait_for(TPDO1, 3, timeout=1.0)[2].timestamp - t < 0.15


def test_remapping_over_sdo_changes_what_is_sent(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE, options={'initial_position': 4242})
    sdo = node.sdo
    # the CiA procedure on TPDO3: disable, sub0 = 0, entries, sub0 = n, enable
    sdo[0x1802][1].raw = 0x80000000 | TPDO3
    sdo[0x1A02][0].raw = 0
    sdo[0x1A02][1].raw = 0x60410010
    sdo[0x1A02][2].raw = 0x60640020
    sdo[0x1A02][0].raw = 2
    sdo[0x1802][2].raw = 1
    sdo[0x1802][1].raw = TPDO3
    # TPDO1 through canopen's own PdoMap.save(), which follows the same procedure
    node.tpdo.read()
    node.tpdo[1].clear()
    node.tpdo[1].add_variable(0x6064)
    node.tpdo[1].trans_type = 1
    node.tpdo[1].enabled = True
    node.tpdo[1].save()
    start(bench, sim)
    t = time.monotonic()
    SyncLoop(bench.master, 0.005).run(2)
    tpdo3 = bench.log.wait_for(TPDO3, 2, since=t)[0]
    statusword, position = struct.unpack('<Hi', tpdo3.data)
    assert state_from_statusword(statusword) is State.SWITCH_ON_DISABLED and position == 4242
    assert bench.log.wait_for(TPDO1, 2, since=t)[0].data == struct.pack('<i', 4242)


def test_mute_is_a_dead_node(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x1017].raw = 10
    start(bench, sim)
    sim.mute(True)
    time.sleep(0.02)
    t = time.monotonic()
    with pytest.raises(canopen.SdoCommunicationError):
        node.sdo.upload(0x1000, 0)
    SyncLoop(bench.master, 0.005).run(4)
    time.sleep(0.05)
    assert not bench.log.frames(since=t), 'no heartbeat, PDO or SDO from a muted node'
    sim.mute(False)
    assert node.sdo[0x1000].raw == 0x00020192
    bench.log.wait_for(HEARTBEAT, since=time.monotonic())


def test_sdo_delay_holds_responses_without_blocking_the_bus(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    start(bench, sim)
    sim.set_sdo_delay(0.1)
    t = time.monotonic()
    bench.send(0x600 + NODE, bytes([0x40, 0x00, 0x10, 0, 0, 0, 0, 0]))  # upload 0x1000
    SyncLoop(bench.master, 0.005).run(2)
    tpdo_time = bench.log.wait_for(TPDO1, since=t)[0].timestamp
    answer = bench.log.wait_for(0x580 + NODE, since=t, timeout=0.5)[0]
    assert answer.data[4:] == struct.pack('<I', 0x00020192)
    assert tpdo_time < answer.timestamp, 'SYNC handled while the SDO answer waits'
    assert answer.timestamp - t >= 0.095
    began = time.monotonic()
    assert node.sdo[0x1000].raw == 0x00020192
    assert 0.095 <= time.monotonic() - began < 0.1 + BUSY_SLACK
    sim.set_sdo_delay(0)


def test_heartbeat_stop_and_start(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x1017].raw = 10
    sim.stop_heartbeat()
    time.sleep(0.02)
    t = time.monotonic()
    time.sleep(0.1)
    assert not bench.log.frames(HEARTBEAT, since=t)
    assert node.sdo[0x1000].raw == 0x00020192, 'everything else still answers'
    sim.start_heartbeat()
    bench.log.wait_for(HEARTBEAT, 3, since=t, timeout=0.5)


def test_master_heartbeat_loss_on_a_301_node_sends_emcy_8130(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE, cls=SimulatedSlave)
    node.sdo[0x1016][1].raw = 127 << 16 | 60
    task = bench.master.send_periodic(0x77F, b'\x05', 0.01)
    try:
        time.sleep(0.1)
        assert not bench.log.frames(EMCY)
    finally:
        task.stop()
    t = time.monotonic()
    emcy = bench.log.wait_for(EMCY, since=t, timeout=0.5)[0]
    code, register = struct.unpack_from('<HB', emcy.data)
    assert (code, register) == (0x8130, 0x11) and emcy.data[3] == 127 and len(emcy.data) == 8
    assert emcy.timestamp - t == pytest.approx(0.06, abs=0.03)
    assert node.sdo[0x1001].raw == 0x11 and node.sdo[0x1003][1].raw == 0x8130
    t = time.monotonic()
    bench.send(0x77F, b'\x05')  # the master is back: error reset
    reset = bench.log.wait_for(EMCY, since=t, timeout=0.5)[0]
    assert reset.data == bytes(8)
    assert node.sdo[0x1001].raw == 0


def test_synchronous_rpdo_after_the_sync_window_is_discarded_until_the_next_sync(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    assert node.sdo[0x1007].raw == 0, 'the generic EDS has 0x1007, window not used by default'
    node.sdo[0x1007].raw = 2000  # µs
    start(bench, sim)
    rpdo2 = 0x300 + NODE  # 0x607A target position, 0x60FF target velocity; transmission type 1

    def target(position: int) -> bytes:
        return struct.pack('<ii', position, 0)

    bench.send(0x080, b'')
    bench.send(rpdo2, target(1111))  # inside the window: applied at the next SYNC
    time.sleep(0.01)
    bench.send(0x080, b'')
    wait_until(lambda: sim.value(0x607A) == 1111, 0.5, 'RPDO inside the window applied')
    time.sleep(0.006)  # the window of that SYNC expired 2 ms after it
    bench.send(rpdo2, target(2222))
    time.sleep(0.01)
    bench.send(0x080, b'')
    time.sleep(0.02)
    assert sim.value(0x607A) == 1111, 'an RPDO received after the window is not applied'
    assert sim.pdo.rpdo_late == 1
    bench.send(0x080, b'')  # a new SYNC opens a new window
    bench.send(rpdo2, target(3333))
    time.sleep(0.01)
    bench.send(0x080, b'')
    wait_until(lambda: sim.value(0x607A) == 3333, 0.5, 'RPDO in the next window applied')
    assert sim.pdo.rpdo_late == 1
    node.sdo[0x1007].raw = 0  # not used: nothing is late
    bench.send(0x080, b'')
    time.sleep(0.01)
    bench.send(rpdo2, target(4444))
    bench.send(0x080, b'')
    wait_until(lambda: sim.value(0x607A) == 4444, 0.5, 'window 0: RPDOs apply whenever received')
    assert sim.pdo.rpdo_late == 1
