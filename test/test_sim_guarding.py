"""Node guarding and life guarding of the simulated slaves (CiA 301 §7.2.8.3.2.1), checked
through CAN frames only: a generic_402 drive without heartbeat objects, polled by RTR frames
from a test-side master on a private virtual channel.

Timing bounds are generous: the life time is 150 ms, the slave checks it every 10 ms, and CI
is a noisy 2-core machine.
"""
from __future__ import annotations

import struct
import time
from collections.abc import Iterator
from typing import Any

import canopen
import pytest

from drive_bridge.cia402.statemachine import State
from drive_bridge.model import BusConfig, BusInterface, SimulationConfig
from drive_bridge.sim import SimDrive402, SimulatedBus, SimulatedSlave
from drive_bridge.sim.options import describe
from drive_bridge.sim.slave import NOTIFIER_CYCLE
from drive_bridge.sim.testing import FrameLog, SimBench, node_config, unique_channel, wait_until
from timingtools import BUSY_SLACK

NODE = 5
GUARD = 0x700 + NODE
EMCY = 0x80 + NODE
RTR_PERIOD = 0.02  # s
LIFE_TIME = 0.150  # s: 0x100C = 50 ms x 0x100D = 3
PRE_OPERATIONAL, OPERATIONAL, STOPPED = 0x7F, 0x05, 0x04


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


def add_guarded(bench: SimBench, **options: Any) -> tuple[Any, canopen.RemoteNode]:
    """A generic_402 drive supervised by guarding only (no heartbeat objects)."""
    return bench.add_drive(NODE, options={'heartbeat': False, **options})


def rtr(bench: SimBench) -> bytes:
    """One guarding request; the reply's data."""
    t = time.monotonic()
    bench.master.send_message(GUARD, b'', remote=True)
    return bench.log.wait_for(GUARD, since=t, timeout=0.5)[0].data


def no_reply(bench: SimBench, wait: float = 0.1) -> bool:
    t = time.monotonic()
    bench.master.send_message(GUARD, b'', remote=True)
    time.sleep(wait)
    return not bench.log.frames(GUARD, since=t)


def set_life_time(node: canopen.RemoteNode, guard_ms: int = 50, factor: int = 3) -> None:
    node.sdo.download(0x100C, 0, struct.pack('<H', guard_ms))
    node.sdo.download(0x100D, 0, struct.pack('<B', factor))


def guard_then_stop(bench: SimBench, duration: float = 0.3) -> float:
    """RTRs every 20 ms for ``duration`` s (life guarding armed and fed), then none: the time they stop."""
    task = bench.master.send_periodic(GUARD, b'', RTR_PERIOD, remote=True)
    try:
        time.sleep(duration)
    finally:
        task.stop()
    return time.monotonic()


def emcy_codes(bench: SimBench, since: float = 0.0) -> list[tuple[int, int]]:
    return [struct.unpack_from('<HB', f.data) for f in bench.log.frames(EMCY, since=since)]


def test_replies_carry_the_toggle_and_the_nmt_state(bench: SimBench) -> None:
    sim, _node = add_guarded(bench)
    assert [rtr(bench), rtr(bench)] == [bytes([PRE_OPERATIONAL]), bytes([0x80 | PRE_OPERATIONAL])]
    bench.nmt(0x01, NODE)
    wait_until(lambda: sim.nmt_state == 'OPERATIONAL', 0.5)
    assert rtr(bench) == bytes([OPERATIONAL])
    bench.nmt(0x02, NODE)
    wait_until(lambda: sim.nmt_state == 'STOPPED', 0.5)
    assert rtr(bench) == bytes([0x80 | STOPPED]), 'guarding is answered in STOPPED too'
    assert sim.guard_replies == 4


def test_a_node_without_heartbeat_objects(bench: SimBench) -> None:
    _sim, node = add_guarded(bench)
    for access in (lambda: node.sdo.upload(0x1017, 0), lambda: node.sdo.download(0x1017, 0, b'\x14\x00'),
                   lambda: node.sdo.upload(0x1016, 1)):
        with pytest.raises(canopen.SdoAbortedError) as err:
            access()
        assert err.value.code == 0x06020000
    set_life_time(node, 50, 3)  # 0x100C / 0x100D exist although the EDS lacks them
    assert struct.unpack('<H', node.sdo.upload(0x100C, 0)) == (50,)
    assert struct.unpack('<B', node.sdo.upload(0x100D, 0)) == (3,)
    time.sleep(0.2)
    assert [f.data for f in bench.log.frames(GUARD)] == [b'\x00'], 'the boot-up frame only, no heartbeat'


@pytest.mark.parametrize('command', [0x82, 0x81])  # reset communication, reset node
def test_a_reset_restarts_the_toggle(bench: SimBench, command: int) -> None:
    sim, _node = add_guarded(bench)
    assert [rtr(bench), rtr(bench)] == [b'\x7f', b'\xff']
    t = time.monotonic()
    bench.nmt(command, NODE)
    assert bench.log.wait_for(GUARD, since=t)[0].data == b'\x00'  # boot-up
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    assert rtr(bench) == b'\x7f', 'toggle 0 in the first reply after the reset'
    assert sim.guard_replies == 1


def test_lost_life_guarding_sends_emcy_8130_and_rtrs_clear_it(bench: SimBench) -> None:
    sim, node = add_guarded(bench)
    set_life_time(node)
    t0 = time.monotonic()
    stopped = guard_then_stop(bench)
    assert not bench.log.frames(EMCY, since=t0), 'no event while the RTRs arrive'
    emcy = bench.log.wait_for(EMCY, since=stopped, timeout=1.0)[0]
    assert struct.unpack_from('<HB', emcy.data) == (0x8130, 0x11)  # communication + generic
    assert 0.1 <= emcy.timestamp - stopped <= LIFE_TIME + 0.35
    assert sim.guarding_lost and sim.error_register == 0x11
    assert sim.axis().state is State.SWITCH_ON_DISABLED, "'emcy': the axes are left alone"
    time.sleep(0.2)
    assert len(bench.log.frames(EMCY, since=stopped)) == 1, 'one EMCY per loss'
    t = time.monotonic()
    assert rtr(bench)[0] & 0x7F == PRE_OPERATIONAL  # the master is back
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes(8)  # error reset
    assert not sim.guarding_lost and sim.error_register == 0
    stopped = guard_then_stop(bench, 0.1)  # re-armed: a new loss is a new event
    bench.log.wait_for(EMCY, since=stopped, timeout=1.0)
    assert emcy_codes(bench, stopped) == [(0x8130, 0x11)]


def test_reset_communication_ends_a_life_guarding_event(bench: SimBench) -> None:
    sim, node = add_guarded(bench)
    set_life_time(node)
    stopped = guard_then_stop(bench)
    bench.log.wait_for(EMCY, since=stopped, timeout=1.0)
    t = time.monotonic()
    bench.nmt(0x82, NODE)
    bench.log.wait_for(GUARD, since=t)  # boot-up
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    assert not sim.guarding_lost and sim.error_register == 0
    assert struct.unpack('<H', node.sdo.upload(0x100C, 0)) == (0,), 'reset communication: 0x100C back to 0'
    time.sleep(LIFE_TIME + 0.1)
    assert not bench.log.frames(EMCY, since=t), 'life guarding waits for the first RTR again'


def test_reaction_none_sends_nothing(bench: SimBench) -> None:
    sim, node = add_guarded(bench, life_guarding_reaction='none')
    set_life_time(node)
    stopped = guard_then_stop(bench)
    wait_until(lambda: sim.guarding_lost, 1.0, 'the life guarding event')
    time.sleep(0.1)
    assert not bench.log.frames(EMCY, since=stopped)
    assert sim.error_register == 0


def test_reaction_fault_faults_the_axis_until_the_master_is_back(bench: SimBench) -> None:
    sim, node = add_guarded(bench, life_guarding_reaction='fault')
    # a life time of BUSY_SLACK: a stall of this process (the RTR sender and the drive run in it)
    # shorter than that is no loss while the RTRs go out
    set_life_time(node, round(BUSY_SLACK * 1000 / 4), 4)
    for cw in (0x06, 0x07, 0x0F):
        node.sdo[0x6040].raw = cw
    assert sim.axis().state is State.OPERATION_ENABLED
    stopped = guard_then_stop(bench)
    emcy = bench.log.wait_for(EMCY, since=stopped, timeout=BUSY_SLACK + BUSY_SLACK)[0]
    assert struct.unpack_from('<HB', emcy.data) == (0x8130, 0x11)
    wait_until(lambda: sim.axis().state is State.FAULT, BUSY_SLACK, 'Fault')
    assert len(bench.log.frames(EMCY, since=stopped)) == 1, 'one EMCY, the axis fault is its consequence'
    node.sdo[0x6040].raw = 0x00
    node.sdo[0x6040].raw = 0x80
    assert sim.axis().state is State.FAULT, 'fault reset refused while the guarding is missing'
    # the master is back: it guards again, and goes on guarding while it resets the fault (one
    # RTR alone re-arms the life time, which a busy machine let run out before the reset came)
    task = bench.master.send_periodic(GUARD, b'', RTR_PERIOD, remote=True)
    try:
        wait_until(lambda: not sim.guarding_lost, BUSY_SLACK, 'the RTRs back on the drive')
        node.sdo[0x6040].raw = 0x00
        node.sdo[0x6040].raw = 0x80
        assert sim.axis().state is State.SWITCH_ON_DISABLED
    finally:
        task.stop()


def test_life_time_factor_zero_switches_life_guarding_off(bench: SimBench) -> None:
    sim, node = add_guarded(bench)
    set_life_time(node, 50, 0)
    stopped = guard_then_stop(bench, 0.1)
    time.sleep(LIFE_TIME + 0.25)
    assert not bench.log.frames(EMCY, since=stopped) and not sim.guarding_lost
    assert rtr(bench)[0] & 0x7F == PRE_OPERATIONAL, 'node guarding itself still works'


def test_stop_guarding_replies(bench: SimBench) -> None:
    sim, node = add_guarded(bench)
    set_life_time(node)
    assert rtr(bench) == b'\x7f'
    sim.stop_guarding_replies()
    t = time.monotonic()
    stopped = guard_then_stop(bench)
    assert not bench.log.frames(GUARD, since=t), 'no reply while switched off'
    assert not bench.log.frames(EMCY, since=t), 'the unanswered RTRs still feed life guarding'
    assert sim.powered and sim.nmt_state == 'PRE-OPERATIONAL'
    bench.log.wait_for(EMCY, since=stopped, timeout=1.0)  # ... until they stop
    sim.stop_guarding_replies(False)
    assert rtr(bench) == b'\xff', 'the toggle goes on from the last reply sent'


def test_repeat_guarding_toggle(bench: SimBench) -> None:
    sim, _node = add_guarded(bench)
    assert rtr(bench) == b'\x7f'
    sim.repeat_guarding_toggle()
    assert [rtr(bench), rtr(bench)] == [b'\x7f', b'\x7f'], 'the same toggle bit again: a guarding error'
    sim.repeat_guarding_toggle(False)
    assert [rtr(bench), rtr(bench)] == [b'\xff', b'\x7f']


def test_a_muted_node_does_not_answer(bench: SimBench) -> None:
    sim, _node = add_guarded(bench)
    sim.mute()
    assert no_reply(bench)
    sim.mute(False)
    assert rtr(bench) == b'\x7f'


class EmcyBootDrive(SimDrive402):
    """A drive family that announces boot-up by an EMCY with 8 zero bytes."""

    def announce_bootup(self) -> None:
        self.send(0x80 + self.node_id, bytes(8))


def test_an_announce_bootup_override_is_used_at_boot(bench: SimBench) -> None:
    sim, _node = bench.add_drive(NODE, options={'heartbeat': False}, cls=EmcyBootDrive, power_on=False)
    t = time.monotonic()
    sim.power_on()
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes(8)
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    assert not bench.log.frames(GUARD, since=t), 'no CiA 301 boot-up frame'
    t = time.monotonic()
    bench.nmt(0x82, NODE)
    assert bench.log.wait_for(EMCY, since=t)[0].data == bytes(8), 'again after reset communication'
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
    assert rtr(bench) == b'\x7f'


@pytest.mark.parametrize('cls, options, message', [
    (SimulatedSlave, {'life_guarding_reaction': 'fault'}, "expected one of 'emcy', 'none', got 'fault'"),
    (SimDrive402, {'life_guarding_reaction': 'stop'}, "expected one of 'emcy', 'none', 'fault'"),
    (SimDrive402, {'heartbeat': 0}, 'expected true or false'),
])
def test_guarding_options_are_validated(cls: type[SimulatedSlave], options: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        cls(node_config(NODE), options=options)


def test_guarding_options_are_documented() -> None:
    text = describe(SimDrive402.OPTIONS)
    assert 'heartbeat (default True)' in text and "life_guarding_reaction (default 'emcy')" in text
    assert "'fault'" in text


def test_nodes_sharing_one_network_answer_their_own_rtrs() -> None:
    channel = unique_channel()
    config = BusConfig(bus=BusInterface(channel=channel),
                       nodes=(node_config(1, 'a'), node_config(2, 'b', family='generic_301')),
                       simulation=SimulationConfig(enabled=True, options={'a': {'heartbeat': False}}))
    master = canopen.Network()
    master.NOTIFIER_CYCLE = NOTIFIER_CYCLE
    master.connect(interface='virtual', channel=channel)
    log = FrameLog(master)
    try:
        with SimulatedBus(config) as bus:
            for node_id in (1, 2):
                log.wait_for(0x700 + node_id)
            wait_until(lambda: all(d.nmt_state == 'PRE-OPERATIONAL' for d in bus.drives.values()), 0.5)
            t = time.monotonic()
            for cob in (0x701, 0x702, 0x701):
                master.send_message(cob, b'', remote=True)
            log.wait_for(0x701, count=2, since=t)
            assert [f.data for f in log.frames(0x701, since=t)] == [b'\x7f', b'\xff']
            assert [f.data for f in log.wait_for(0x702, since=t)] == [b'\x7f']
            assert bus.drive('a').guard_replies == 2 and bus.drive('b').guard_replies == 1
    finally:
        master.disconnect()
