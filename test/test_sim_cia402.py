"""CiA 402 behaviour of SimDrive402, driven like a master does: SDO, RPDOs before
SYNC, TPDOs after it. Simulator state is read only to check what was achieved."""
from __future__ import annotations

import struct
import time
from collections.abc import Iterator

import canopen
import pytest

from drive_bridge.cia402.statemachine import (
    SW_FAULT,
    SW_INTERNAL_LIMIT,
    SW_OMS_12,
    SW_OMS_13,
    SW_TARGET_REACHED,
    SW_WARNING,
    State,
    state_from_statusword,
)
from drive_bridge.sim import SimDrive402
from drive_bridge.sim.testing import GENERIC402_2AXIS_EDS, SimBench, SyncLoop, wait_until

NODE = 5
RPDO1, RPDO2 = 0x200 + NODE, 0x300 + NODE
TPDO1, TPDO2, TPDO3 = 0x180 + NODE, 0x280 + NODE, 0x380 + NODE
EMCY = 0x80 + NODE
PERIOD = 0.004  # s, SYNC period of these tests (= the EDS default of 0x60C2)


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


def rpdo1(cw: int, mode: int, torque: int = 0) -> bytes:
    return struct.pack('<Hbh', cw, mode, torque)


def rpdo2(position: int, velocity: int = 0) -> bytes:
    return struct.pack('<ii', position, velocity)


def state_of(node: canopen.RemoteNode, slot: int = 0) -> State:
    return state_from_statusword(node.sdo[0x6041 + 0x800 * slot].raw)


def write_cw(node: canopen.RemoteNode, cw: int, slot: int = 0) -> None:
    node.sdo[0x6040 + 0x800 * slot].raw = cw


def enable(node: canopen.RemoteNode, mode: int, slot: int = 0) -> None:
    node.sdo[0x6060 + 0x800 * slot].raw = mode
    for cw in (0x06, 0x07, 0x0F):
        write_cw(node, cw, slot)
    assert state_of(node, slot) is State.OPERATION_ENABLED
    assert node.sdo[0x6061 + 0x800 * slot].raw == mode


def operational(bench: SimBench, sim: SimDrive402) -> None:
    bench.nmt(0x01, NODE)
    wait_until(lambda: sim.nmt_state == 'OPERATIONAL', 0.5, 'OPERATIONAL')


def last_tpdo1(bench: SimBench) -> tuple[int, int, int]:
    return struct.unpack('<Hbh', bench.log.frames(TPDO1)[-1].data)


def last_tpdo2(bench: SimBench) -> tuple[int, int]:
    return struct.unpack('<ii', bench.log.frames(TPDO2)[-1].data)


def test_state_machine_walked_by_sdo(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    walk = [  # (controlword, state expected afterwards)  transition numbers of CiA 402
        (0x0F, State.SWITCH_ON_DISABLED),  # no transition from SOD but shutdown
        (0x86, State.SWITCH_ON_DISABLED),  # bit 7 set: no device control command
        (0x06, State.READY_TO_SWITCH_ON),  # 2
        (0x07, State.SWITCHED_ON),  # 3
        (0x0F, State.OPERATION_ENABLED),  # 4
        (0x07, State.SWITCHED_ON),  # 5 (0x605C = 1: ramp first)
        (0x06, State.READY_TO_SWITCH_ON),  # 6
        (0x02, State.SWITCH_ON_DISABLED),  # 7 (quick stop)
        (0x06, State.READY_TO_SWITCH_ON),
        (0x0F, State.OPERATION_ENABLED),  # 3 + 4
        (0x06, State.READY_TO_SWITCH_ON),  # 8
        (0x07, State.SWITCHED_ON),
        (0x00, State.SWITCH_ON_DISABLED),  # 10
        (0x06, State.READY_TO_SWITCH_ON),
        (0x0F, State.OPERATION_ENABLED),
        (0x00, State.SWITCH_ON_DISABLED),  # 9
        (0x06, State.READY_TO_SWITCH_ON),
        (0x0F, State.OPERATION_ENABLED),
        (0x0B, State.SWITCH_ON_DISABLED),  # 11, then 12 automatically (0x605A = 2)
    ]
    for cw, expected in walk:
        write_cw(node, cw)
        wait_until(lambda: state_of(node) is expected, 0.5, f'{expected.label} after 0x{cw:02X}')
        assert sim.axis().controlword == cw
    sw = node.sdo[0x6041].raw
    assert sw & 0x0200, 'remote'


def test_state_machine_over_rpdo_applied_at_sync(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    operational(bench, sim)
    sync = SyncLoop(bench.master, PERIOD)
    bench.send(RPDO1, rpdo1(0x06, 0))
    time.sleep(0.02)
    assert sim.axis().state is State.SWITCH_ON_DISABLED, 'a synchronous RPDO waits for SYNC'
    seen = []
    for cw in (0x06, 0x07, 0x0F):
        t = time.monotonic()
        bench.send(RPDO1, rpdo1(cw, 8))
        sync.sync()
        frame = bench.log.wait_for(TPDO1, since=t, timeout=0.2)[0]
        seen.append(state_from_statusword(struct.unpack_from('<H', frame.data)[0]))
    assert seen == [State.READY_TO_SWITCH_ON, State.SWITCHED_ON, State.OPERATION_ENABLED]
    assert last_tpdo1(bench)[1] == 8, 'modes of operation display follows 0x6060 from the RPDO'
    sim.drop_rpdos(True)
    bench.send(RPDO1, rpdo1(0x00, 8))
    sync.run(3)
    assert sim.axis().state is State.OPERATION_ENABLED, 'dropped RPDOs are ignored'
    sim.drop_rpdos(False)
    bench.send(RPDO1, rpdo1(0x00, 8))
    sync.run(2)
    wait_until(lambda: sim.axis().state is State.SWITCH_ON_DISABLED, 0.2)


def test_profile_position_with_set_point_handshake(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    enable(node, 1)
    operational(bench, sim)
    sync = SyncLoop(bench.master, PERIOD)
    cw = {'value': 0x1F}

    def before(i: int) -> None:
        bench.send(RPDO2, rpdo2(20000))
        bench.send(RPDO1, rpdo1(cw['value'], 1))

    def acknowledged() -> bool:
        frames = bench.log.frames(TPDO1)
        return bool(frames) and bool(struct.unpack_from('<H', frames[-1].data)[0] & SW_OMS_12)

    sync.run_until(acknowledged, 0.5, before, 'set-point acknowledge (bit 12)')
    assert not last_tpdo1(bench)[0] & SW_TARGET_REACHED
    cw['value'] = 0x0F
    sync.run(3, before)
    sw = last_tpdo1(bench)[0]
    assert not sw & SW_OMS_12, 'ack drops with bit 4'
    assert not sw & SW_TARGET_REACHED, 'moving'

    def reached() -> bool:
        return bool(last_tpdo1(bench)[0] & SW_TARGET_REACHED)

    sync.run_until(reached, 2.0, before, 'target reached')
    position, _velocity = last_tpdo2(bench)
    assert abs(position - 20000) <= node.sdo[0x6067].raw
    time.sleep(0.08)  # SYNC silent for 50 ms: the drive's own clock takes over
    assert node.sdo[0x6064].raw == pytest.approx(20000, abs=2) and node.sdo[0x606C].raw == 0
    # relative move (bit 6) while bit 4 rises again
    node.sdo[0x607A].raw = -5000
    write_cw(node, 0x5F)
    assert node.sdo[0x6041].raw & SW_OMS_12
    write_cw(node, 0x4F)
    wait_until(lambda: node.sdo[0x6041].raw & SW_TARGET_REACHED and not sim.axis().velocity, 2.0)
    assert sim.axis().position == pytest.approx(15000, abs=5)


def test_software_position_limits_clamp_the_target_and_set_bit_11(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x607D][1].raw = -1000
    node.sdo[0x607D][2].raw = 2000
    node.sdo[0x607A].raw = 5000
    enable(node, 1)
    write_cw(node, 0x1F)
    write_cw(node, 0x0F)
    wait_until(lambda: node.sdo[0x6041].raw & SW_TARGET_REACHED and sim.axis().position == 2000, 2.0)
    assert node.sdo[0x6041].raw & SW_INTERNAL_LIMIT
    node.sdo[0x607A].raw = 0
    write_cw(node, 0x1F)
    write_cw(node, 0x0F)
    wait_until(lambda: node.sdo[0x6041].raw & SW_TARGET_REACHED and sim.axis().position == 0, 2.0)
    assert not node.sdo[0x6041].raw & SW_INTERNAL_LIMIT


def test_profile_velocity_without_sync(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x60FF].raw = 20000
    enable(node, 3)
    t = time.monotonic()
    wait_until(lambda: node.sdo[0x6041].raw & SW_TARGET_REACHED, 1.0, 'velocity reached')
    assert time.monotonic() - t >= 0.03  # 20000 / 500000 counts/s^2 = 40 ms ramp
    assert node.sdo[0x606C].raw == pytest.approx(20000, abs=100)
    time.sleep(0.03)
    assert node.sdo[0x6077].raw == pytest.approx(20, abs=2)  # friction 1e-3 per mille per count/s
    node.sdo[0x60FF].raw = 0
    wait_until(lambda: abs(node.sdo[0x606C].raw) < 1, 1.0, 'standstill')
    assert node.sdo[0x6041].raw & SW_OMS_12, 'PV bit 12: speed = 0'


def stream_csp(bench: SimBench, targets: list[int], errors: list[int] | None = None,
               sim: SimDrive402 | None = None) -> None:
    def before(i: int) -> None:
        bench.send(RPDO1, rpdo1(0x0F, 8))
        bench.send(RPDO2, rpdo2(targets[i]))

    def after(i: int) -> None:
        if errors is not None and sim is not None:
            errors.append(sim.axis().following_error)

    SyncLoop(bench.master, PERIOD).run(len(targets), before, after)


def test_cyclic_sync_position_follows_a_streamed_ramp(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE, options={'initial_position': 1000})
    node.sdo[0x607A].raw = node.sdo[0x6064].raw  # the master's duty before enabling CSP
    enable(node, 8)
    operational(bench, sim)
    targets = [1000 + 80 * i for i in range(100)] + [1000 + 80 * 99] * 25  # 20000 counts/s, then hold
    errors: list[int] = []
    stream_csp(bench, targets, errors, sim)
    assert max(abs(e) for e in errors) < 400  # v * tau = 40 counts; SYNC jitter of a few ms on top
    assert max(abs(e) for e in errors[20:100]) > 10, 'a real lag, not a copy'
    assert sim.axis().state is State.OPERATION_ENABLED
    assert sim.axis().position == pytest.approx(targets[-1], abs=3)
    sw = last_tpdo1(bench)[0]
    assert sw & SW_OMS_12 and not sw & SW_OMS_13, 'follows the target, no following error'


def test_following_error_fault_when_the_target_jumps(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    enable(node, 8)
    operational(bench, sim)
    t = time.monotonic()
    stream_csp(bench, [0] * 5 + [1_000_000] * 25)
    emcy = bench.log.wait_for(EMCY, since=t, timeout=0.5)[0]
    assert struct.unpack_from('<HB', emcy.data) == (0x8611, 0x21)
    stream_csp(bench, [1_000_000] * 25)
    wait_until(lambda: sim.axis().state is State.FAULT, 0.5)
    assert node.sdo[0x603F].raw == 0x8611
    assert node.sdo[0x6041].raw & SW_FAULT


def test_cyclic_sync_velocity_and_torque(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    enable(node, 9)
    operational(bench, sim)
    sync = SyncLoop(bench.master, PERIOD)

    def csv(i: int) -> None:
        bench.send(RPDO1, rpdo1(0x0F, 9))
        bench.send(RPDO2, rpdo2(0, 10000))

    sync.run(50, csv)
    position, velocity = last_tpdo2(bench)
    assert velocity == pytest.approx(10000, abs=200)
    assert 1000 < position < 3000  # about 0.2 s at 10000 counts/s
    node.sdo[0x60B1].raw = 5000  # velocity offset adds
    sync.run(25, csv)
    assert last_tpdo2(bench)[1] == pytest.approx(15000, abs=300)

    def cst(i: int) -> None:
        bench.send(RPDO1, rpdo1(0x0F, 10, 100))

    before = sim.axis().velocity
    sync.run(50, cst)
    status, mode, torque = last_tpdo1(bench)
    assert mode == 10 and torque == pytest.approx(100, abs=2) and status & SW_OMS_12
    assert sim.axis().velocity > before + 5000, 'the torque accelerates the load'


def test_homing_method_35_and_37_set_the_home_offset(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE, options={'initial_position': 5000})
    node.sdo[0x607C].raw = 1000
    enable(node, 6)
    sw = node.sdo[0x6041].raw
    assert sw & SW_TARGET_REACHED and not sw & SW_OMS_12, 'not started'
    write_cw(node, 0x1F)
    wait_until(lambda: node.sdo[0x6041].raw & (SW_OMS_12 | SW_TARGET_REACHED) == SW_OMS_12 | SW_TARGET_REACHED,
               0.5, 'homing attained')
    assert node.sdo[0x6064].raw == 1000 and sim.axis().position == 1000
    write_cw(node, 0x0F)
    node.sdo[0x6098].raw = 37
    node.sdo[0x607C].raw = -20
    write_cw(node, 0x1F)
    wait_until(lambda: node.sdo[0x6064].raw == -20, 0.5)


def test_homing_on_a_switch_and_homing_errors(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE, options={'home_switch_position': 3000, 'homing_timeout': 2.0})
    node.sdo[0x6098].raw = 19  # home switch: search toward it, creep back to its edge
    enable(node, 6)
    write_cw(node, 0x1F)
    time.sleep(0.03)
    assert not node.sdo[0x6041].raw & (SW_OMS_12 | SW_TARGET_REACHED), 'in progress'
    done = SW_OMS_12 | SW_TARGET_REACHED
    wait_until(lambda: node.sdo[0x6041].raw & done == done, 2.0, 'homing attained, at standstill')
    assert sim.axis().position == pytest.approx(0, abs=1)
    assert not node.sdo[0x6041].raw & SW_OMS_13
    write_cw(node, 0x0F)
    node.sdo[0x6098].raw = 15  # reserved method
    write_cw(node, 0x1F)
    wait_until(lambda: node.sdo[0x6041].raw & SW_OMS_13, 0.5, 'homing error for an unsupported method')
    write_cw(node, 0x0F)
    node.sdo[0x6098].raw = 1  # negative limit switch, but the switch lies ahead: times out
    sim.axis().switch_position = 10_000_000
    sim.axis().homing_timeout = 0.2
    write_cw(node, 0x1F)
    wait_until(lambda: node.sdo[0x6041].raw & SW_OMS_13, 1.5, 'homing error after the timeout')


def test_interpolated_position_with_buffered_points(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    with pytest.raises(canopen.SdoAbortedError):
        node.sdo[0x60C0].raw = -1
    assert node.sdo[0x60C4][1].raw == 16
    enable(node, 7)
    for point in (100, 200, 300, 400, 500):
        node.sdo[0x60C1][1].raw = point
    assert node.sdo[0x60C4][2].raw == 11, 'free places'
    assert not node.sdo[0x6041].raw & SW_OMS_12
    operational(bench, sim)
    sync = SyncLoop(bench.master, PERIOD)
    sync.run(3, lambda i: bench.send(RPDO1, rpdo1(0x0F, 7)))
    assert sim.axis().position == 0, 'bit 4 not set: IP not active'
    t = time.monotonic()
    sync.run(10, lambda i: bench.send(RPDO1, rpdo1(0x1F, 7)))
    assert last_tpdo1(bench)[0] & SW_OMS_12, 'IP mode active'
    positions = [struct.unpack_from('<i', f.data)[0] for f in bench.log.wait_for(TPDO2, 10, since=t)]
    steps = [b - a for a, b in zip(positions, positions[1:])]
    assert min(steps) >= 0 and max(steps) <= 160, 'one point per SYNC, linear in between'
    assert node.sdo[0x60C4][2].raw == 16
    wait_until(lambda: node.sdo[0x6041].raw & SW_TARGET_REACHED, 0.5)
    assert sim.axis().position == pytest.approx(500, abs=2)
    write_cw(node, 0x0F)  # IP inactive: nothing consumed
    for _point in range(17):  # one too many
        node.sdo[0x60C1][1].raw = 600
    assert node.sdo[0x6041].raw & SW_WARNING and node.sdo[0x60C4][2].raw == 0
    node.sdo[0x60C4][6].raw = 0  # clear (and disable access)
    node.sdo[0x60C1][1].raw = 700
    assert node.sdo[0x60C4][2].raw == 16 and not node.sdo[0x6041].raw & SW_WARNING
    node.sdo[0x60C4][6].raw = 1
    node.sdo[0x60C1][1].raw = 700
    assert node.sdo[0x60C4][2].raw == 15


def test_halt_decelerates_and_stays_enabled(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x60FF].raw = 20000
    enable(node, 3)
    wait_until(lambda: node.sdo[0x606C].raw > 19900, 1.0)
    t = time.monotonic()
    write_cw(node, 0x10F)
    wait_until(lambda: sim.axis().velocity == 0, 1.0, 'halted')
    assert time.monotonic() - t >= 0.03  # 20000 / 500000 (0x6084) = 40 ms
    sw = node.sdo[0x6041].raw
    assert state_from_statusword(sw) is State.OPERATION_ENABLED and sw & SW_TARGET_REACHED
    write_cw(node, 0x0F)
    wait_until(lambda: node.sdo[0x606C].raw > 19900, 1.0, 'running again after the halt')


@pytest.mark.parametrize('option, final', [(2, State.SWITCH_ON_DISABLED), (6, State.QUICK_STOP_ACTIVE)])
def test_quick_stop_option(bench: SimBench, option: int, final: State) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x605A].raw = option
    node.sdo[0x6085].raw = 200000  # quick-stop deceleration: 0.1 s from 20000 counts/s
    node.sdo[0x60FF].raw = 20000
    enable(node, 3)
    wait_until(lambda: node.sdo[0x606C].raw > 19900, 1.0)
    write_cw(node, 0x0B)
    assert state_of(node) is State.QUICK_STOP_ACTIVE
    wait_until(lambda: sim.axis().velocity == 0, 1.0, 'stopped')
    wait_until(lambda: state_of(node) is final, 0.2, final.label)
    write_cw(node, 0x0F)  # transition 16 only for options 5..8
    time.sleep(0.03)
    expected = State.OPERATION_ENABLED if option >= 5 else State.SWITCH_ON_DISABLED
    assert state_of(node) is expected


def test_injected_fault_emcy_statusword_and_error_objects(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    enable(node, 3)
    t = time.monotonic()
    sim.inject_fault(0x2310, manufacturer=b'\x01\x02\x03\x04\x05')
    emcy = bench.log.wait_for(EMCY, since=t)[0]
    assert emcy.data == bytes([0x10, 0x23, 0x03, 1, 2, 3, 4, 5])  # code LE, register: generic + current
    wait_until(lambda: state_of(node) is State.FAULT, 0.5)
    assert node.sdo[0x6041].raw & SW_FAULT
    assert node.sdo[0x603F].raw == 0x2310
    assert node.sdo[0x1001].raw == 0x03
    assert node.sdo[0x1003][0].raw == 1 and node.sdo[0x1003][1].raw == 0x2310
    sim.inject_fault(0x4210)
    assert node.sdo[0x1003][0].raw == 2 and node.sdo[0x1003][1].raw == 0x4210, 'newest first'
    assert node.sdo[0x1003][2].raw == 0x2310
    node.sdo[0x1003][0].raw = 0
    assert node.sdo[0x1003][0].raw == 0


def test_fault_reset_on_the_rising_edge_only(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    enable(node, 3)
    write_cw(node, 0x80)  # bit 7 held before the fault
    sim.inject_fault(0x5530)
    wait_until(lambda: state_of(node) is State.FAULT, 0.5)
    write_cw(node, 0x80)  # still held: no edge
    time.sleep(0.02)
    assert state_of(node) is State.FAULT
    write_cw(node, 0x00)
    assert state_of(node) is State.FAULT
    t = time.monotonic()
    write_cw(node, 0x80)  # rising edge
    assert state_of(node) is State.SWITCH_ON_DISABLED
    assert node.sdo[0x603F].raw == 0
    reset = bench.log.wait_for(EMCY, since=t)[0]
    assert reset.data == bytes(8), 'EMCY 0x0000: all errors reset'
    assert node.sdo[0x1001].raw == 0


def test_persistent_fault_needs_its_cause_cleared(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    sim.inject_fault(0x4310, persistent=True)
    wait_until(lambda: state_of(node) is State.FAULT, 0.5)
    for _ in range(2):
        write_cw(node, 0x00)
        write_cw(node, 0x80)
        assert state_of(node) is State.FAULT, 'the cause persists'
    sim.clear_fault_cause()
    write_cw(node, 0x00)
    write_cw(node, 0x80)
    assert state_of(node) is State.SWITCH_ON_DISABLED


def test_master_heartbeat_loss_faults_the_drive(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE)
    node.sdo[0x1016][1].raw = 127 << 16 | 60
    node.sdo[0x60FF].raw = 20000
    task = bench.master.send_periodic(0x77F, b'\x05', 0.01)
    try:
        enable(node, 3)
        wait_until(lambda: sim.axis().velocity > 19900, 1.0)
    finally:
        task.stop()
    t = time.monotonic()
    emcy = bench.log.wait_for(EMCY, since=t, timeout=0.5)[0]
    assert struct.unpack_from('<H', emcy.data)[0] == 0x8130
    wait_until(lambda: sim.axis().state is State.FAULT, 0.5, 'fault reaction done')
    assert abs(sim.axis().velocity) <= 1
    assert node.sdo[0x603F].raw == 0x8130
    write_cw(node, 0x00)
    write_cw(node, 0x80)
    assert state_of(node) is State.FAULT, 'no reset while the master heartbeat is missing'
    bench.send(0x77F, b'\x05')
    time.sleep(0.01)
    t = time.monotonic()
    write_cw(node, 0x00)
    write_cw(node, 0x80)
    assert state_of(node) is State.SWITCH_ON_DISABLED
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes(8)


def test_two_axis_node_moves_each_axis_independently(bench: SimBench) -> None:
    sim, node = bench.add_drive(NODE, eds=GENERIC402_2AXIS_EDS, options={'initial_position': [0, 500]})
    assert len(sim.axes) == 2
    node.sdo[0x607A].raw = 3000
    enable(node, 1, slot=0)
    node.sdo[0x68FF].raw = -5000
    enable(node, 3, slot=1)
    write_cw(node, 0x1F, slot=0)
    write_cw(node, 0x0F, slot=0)
    wait_until(lambda: node.sdo[0x6041].raw & SW_TARGET_REACHED and sim.axis(0).position == 3000, 2.0)
    assert node.sdo[0x686C].raw == pytest.approx(-5000, abs=50)
    assert sim.axis(1).position < 0
    write_cw(node, 0x00, slot=1)
    assert state_of(node, 1) is State.SWITCH_ON_DISABLED and state_of(node, 0) is State.OPERATION_ENABLED
    operational(bench, sim)
    t = time.monotonic()
    SyncLoop(bench.master, PERIOD).run(2)
    status1, mode1, _torque = struct.unpack('<Hbh', bench.log.wait_for(TPDO3, since=t)[0].data)
    assert state_from_statusword(status1) is State.SWITCH_ON_DISABLED and mode1 == 3
    status0, mode0, _torque = struct.unpack('<Hbh', bench.log.wait_for(TPDO1, since=t)[0].data)
    assert state_from_statusword(status0) is State.OPERATION_ENABLED and mode0 == 1
    sim.inject_fault(0x7300, axis=1)
    wait_until(lambda: state_of(node, 1) is State.FAULT, 0.5)
    assert node.sdo[0x683F].raw == 0x7300 and node.sdo[0x603F].raw == 0
    assert state_of(node, 0) is State.OPERATION_ENABLED
