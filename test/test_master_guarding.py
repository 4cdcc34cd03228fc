"""CiA 301 node guarding, master side (drive_bridge.master.guarding), at frame level.

The master side is a canopen Network on a python-can ``virtual`` bus; the node is a tiny
responder written here (a python-can Listener answering the RTRs on 0x705), not the
simulator. Timing bounds are generous: CI is a noisy 2-core machine.
"""
from __future__ import annotations

import itertools
import os
import re
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass

import can
import canopen
import pytest

from drive_bridge.master.guarding import GuardEvent, GuardEventKind, NodeGuard, configure_guarding
from drive_bridge.model import NodeConfig
from timingtools import BUSY_SLACK
from waittools import wait_for

NODE_ID = 5
COB_ID = 0x700 + NODE_ID
GUARD_TIME = 0.05  # s
LIFE_TIME_FACTOR = 3
LIFE_TIME = GUARD_TIME * LIFE_TIME_FACTOR
SUPERVISOR_PERIOD = 0.02  # as the master's supervisor polls
# LOST comes at most this late after the life time: one poll period plus scheduling on a busy
# machine (the latency itself: `python -m bench reactions`)
LOST_MARGIN = BUSY_SLACK
OPERATIONAL = 5

_channels = itertools.count()


class GuardedNode(can.Listener):
    """A node that has no heartbeat and answers node guarding: one byte, toggle in bit 7
    (0 first, alternating), NMT state in bits 0..6."""

    def __init__(self, bus: can.BusABC, state: int = OPERATIONAL) -> None:
        self.bus = bus
        self.state = state
        self.toggle = 0
        self.answer = True
        self.repeat_toggle = False  # a faulty node: never alternates
        self.requests: list[can.Message] = []
        self.last_answer = 0.0

    def on_message_received(self, msg: can.Message) -> None:
        if msg.arbitration_id != COB_ID or not msg.is_remote_frame:
            return
        self.requests.append(msg)
        if not self.answer:
            return
        self.bus.send(can.Message(arbitration_id=COB_ID, is_extended_id=False, data=[self.toggle << 7 | self.state]))
        self.last_answer = time.monotonic()
        if not self.repeat_toggle:
            self.toggle ^= 1

    def boot_up(self) -> None:
        """Reset communication: the boot-up message, and the toggle starts at 0 again."""
        self.toggle = 0
        self.bus.send(can.Message(arbitration_id=COB_ID, is_extended_id=False, data=[0]))


@dataclass
class Bench:
    network: canopen.Network
    node: GuardedNode


@pytest.fixture
def bench(request: pytest.FixtureRequest) -> Iterator[Bench]:
    channel = f'guarding-{os.getpid()}-{next(_channels)}-{request.node.name}'
    network = canopen.Network()
    network.NOTIFIER_CYCLE = 0.05  # a quick disconnect
    network.connect(interface='virtual', channel=channel)
    node_bus = can.Bus(interface='virtual', channel=channel)
    node = GuardedNode(node_bus)
    notifier = can.Notifier(node_bus, [node], timeout=0.01)
    try:
        yield Bench(network, node)
    finally:
        notifier.stop()
        node_bus.shutdown()
        network.disconnect()


class Supervisor:
    """Polls a guard every 20 ms in its own thread, like the master's supervisor."""

    def __init__(self, guard: NodeGuard) -> None:
        self.guard = guard
        self.events: list[tuple[float, GuardEvent]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop.wait(SUPERVISOR_PERIOD):
            now = time.monotonic()
            self.events.extend((now, event) for event in self.guard.poll(now))

    def kinds(self) -> list[GuardEventKind]:
        return [event.kind for _, event in self.events]

    def first(self, kind: GuardEventKind) -> tuple[float, GuardEvent] | None:
        return next(((t, e) for t, e in self.events if e.kind is kind), None)

    def __enter__(self) -> Supervisor:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=2)


def guarded(bench: Bench, guard_time: float = GUARD_TIME) -> NodeGuard:
    guard = NodeGuard(NODE_ID, guard_time, LIFE_TIME_FACTOR)
    guard.attach(bench.network)
    return guard


def test_rtrs_go_out_at_the_guard_time_and_replies_keep_the_node_alive(bench: Bench) -> None:
    guard_time = 0.2  # a life time of 0.6 s: longer than a busy machine holds the node's thread
    guard = guarded(bench, guard_time)
    started = time.monotonic()
    with Supervisor(guard) as supervisor:
        time.sleep(1.0)
    took = time.monotonic() - started
    time.sleep(0.05)  # the last RTR and its reply are through
    sent = len(bench.node.requests)
    # about 5: never more often than the guard time, fewer on a busy machine
    assert 2 <= sent <= took / guard_time + 2, f'{sent} RTRs in {took:.2f} s at a guard time of 200 ms'
    assert all(m.is_remote_frame and m.arbitration_id == COB_ID and m.dlc == 1 for m in bench.node.requests)
    assert supervisor.events == []
    status = guard.status(time.monotonic())
    assert status.replies >= sent - 2 and status.requests == sent
    assert (status.lost, status.nmt_state, status.toggle_errors) == (False, OPERATIONAL, 0)
    assert status.age is not None and status.age < LIFE_TIME_FACTOR * guard_time
    guard.detach()


def test_silence_is_lost_within_the_life_time_and_replies_bring_it_back(bench: Bench) -> None:
    guard = guarded(bench)
    with Supervisor(guard) as supervisor:
        wait_for(lambda: guard.status(time.monotonic()).replies >= 3, 2, 'three replies')
        bench.node.answer = False
        time.sleep(0.01)  # a reply being sent right now is the last one
        silent_since = bench.node.last_answer
        found = wait_for(lambda: supervisor.first(GuardEventKind.LOST), 3, 'LOST')
        lost_at, lost = found
        assert LIFE_TIME - 0.01 < lost_at - silent_since <= LIFE_TIME + LOST_MARGIN
        assert re.fullmatch(r'node 5: node guarding lost: no valid reply for \d+ ms '
                            r'\(node life time 150 ms = guard time 50 ms x life time factor 3\)', lost.message)
        assert lost.node_id == NODE_ID and lost.nmt_state == OPERATIONAL
        assert lost.age is not None and lost.age > LIFE_TIME
        assert guard.lost
        time.sleep(3 * GUARD_TIME)  # RTRs go on while the node is lost; LOST is reported once
        assert len(bench.node.requests) > 3
        assert supervisor.kinds() == [GuardEventKind.LOST]
        bench.node.answer = True
        _, back = wait_for(lambda: supervisor.first(GuardEventKind.BACK), 3, 'BACK')
    assert back.message.startswith('node 5: node guarding back: valid reply (operational) after ')
    assert back.nmt_state == OPERATIONAL and back.age == 0.0  # the reply that brought it back
    assert supervisor.kinds() == [GuardEventKind.LOST, GuardEventKind.BACK]
    assert not guard.lost
    guard.detach()


def test_a_repeated_toggle_is_a_toggle_error_and_no_sign_of_life(bench: Bench) -> None:
    guard = guarded(bench)
    with Supervisor(guard) as supervisor:
        wait_for(lambda: guard.status(time.monotonic()).replies >= 3, 2, 'three replies')
        bench.node.repeat_toggle = True
        _, error = wait_for(lambda: supervisor.first(GuardEventKind.TOGGLE_ERROR), 2, 'TOGGLE_ERROR')
        # the node keeps repeating it: every reply is ignored, so the node is lost too
        wait_for(lambda: supervisor.first(GuardEventKind.LOST), 2, 'LOST')
    repeated = bench.node.toggle
    assert error.message == (f'node 5: node guarding toggle error: toggle bit {repeated} repeated, expected '
                             f'{1 - repeated} (1 toggle error(s) since reset); reply ignored')
    assert error.toggle_errors == 1 and error.nmt_state == OPERATIONAL
    errors = [e for _, e in supervisor.events if e.kind is GuardEventKind.TOGGLE_ERROR]
    assert [e.toggle_errors for e in errors] == list(range(1, len(errors) + 1))
    assert len(errors) >= 2
    guard.detach()


def _exchange(guard: NodeGuard) -> tuple[GuardEvent, ...]:
    """Poll until one RTR went out and its reply was judged; the events of those polls."""
    start = guard.status(time.monotonic())
    events: list[GuardEvent] = []

    def sent() -> bool:
        events.extend(guard.poll(time.monotonic()))
        return guard.status(time.monotonic()).requests > start.requests

    wait_for(sent, 2, 'an RTR')

    def judged() -> bool:
        status = guard.status(time.monotonic())
        return status.replies + status.toggle_errors > start.replies + start.toggle_errors

    wait_for(judged, 2, 'the reply')
    events.extend(guard.poll(time.monotonic()))
    return tuple(events)


def test_reset_expects_toggle_0_again(bench: Bench) -> None:
    guard = guarded(bench, guard_time=0.1)  # polled by hand here
    assert _exchange(guard) == ()  # toggle 0: the first reply
    bench.node.toggle = 0  # the node restarted its toggle, unknown to the master
    (error,) = _exchange(guard)
    assert error.kind is GuardEventKind.TOGGLE_ERROR
    assert 'toggle bit 0 repeated, expected 1' in error.message
    guard.reset()  # the master knows the node was reset
    bench.node.toggle = 0
    assert _exchange(guard) == ()
    assert guard.status(time.monotonic()).toggle_errors == 0
    assert _exchange(guard) == ()  # toggle 1
    guard.reset()
    bench.node.toggle = 1  # after a reset the first reply must carry toggle 0
    (error,) = _exchange(guard)
    assert error.message == ('node 5: node guarding toggle error: toggle bit 1 in the first reply after boot-up '
                             'or reset, expected 0 (1 toggle error(s) since reset); reply ignored')
    guard.detach()


def test_a_boot_up_message_restarts_the_toggle(bench: Bench) -> None:
    guard = guarded(bench, guard_time=0.1)
    assert _exchange(guard) == ()  # toggle 0
    bench.node.boot_up()
    time.sleep(0.05)
    assert _exchange(guard) == ()  # toggle 0 again, accepted
    assert guard.status(time.monotonic()).replies == 2
    guard.detach()


def test_a_detached_guard_sends_nothing(bench: Bench) -> None:
    guard = guarded(bench)
    assert _exchange(guard) == ()
    guard.detach()
    time.sleep(2 * GUARD_TIME)
    assert guard.poll(time.monotonic()) == ()
    time.sleep(0.05)
    assert len(bench.node.requests) == 1


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_schedule_follows_the_guard_time_without_bursts() -> None:
    sent: list[float] = []
    clock = FakeClock()
    guard = NodeGuard(NODE_ID, 0.1, 3, send_rtr=lambda: sent.append(clock.now), clock=clock)
    for _ in range(50):  # 1 s of 20 ms polls (no replies: RTRs go on while the node is lost)
        guard.poll(clock.now)
        clock.now += 0.02
    assert len(sent) == 10
    clock.now += 1.0  # the supervisor stalled for 1 s: one RTR, then the guard time again
    guard.poll(clock.now)
    guard.poll(clock.now + 0.02)
    assert len(sent) == 11
    guard.poll(clock.now + 0.1)
    assert len(sent) == 12


def test_a_failed_send_is_named_in_lost_and_never_raised() -> None:
    clock = FakeClock()

    def broken() -> None:
        raise can.CanOperationError('Transmit buffer full')

    guard = NodeGuard(NODE_ID, 0.1, 2, send_rtr=broken, clock=clock)
    events: list[GuardEvent] = []
    for _ in range(15):
        events.extend(guard.poll(clock.now))
        clock.now += 0.02
    (lost,) = events
    assert lost.kind is GuardEventKind.LOST and lost.age is None and lost.nmt_state is None
    assert re.fullmatch(r'node 5: node guarding lost: no reply to any RTR for 2\d\d ms \(node life time 200 ms = '
                        r'guard time 100 ms x life time factor 2\); last RTR send failed: CanOperationError: '
                        r'Transmit buffer full', lost.message)


def test_guard_from_config_and_argument_checks() -> None:
    config = NodeConfig('servo', NODE_ID, 'generic_301', canopen.ObjectDictionary(), heartbeat_producer_ms=0,
                        guard_time_ms=200, life_time_factor=4)
    guard = NodeGuard.from_config(config)
    assert (guard.node_id, guard.cob_id, guard.guard_time, guard.life_time) == (5, 0x705, 0.2, pytest.approx(0.8))
    with pytest.raises(ValueError, match=r'node 5 \(servo\) is not guarded'):
        NodeGuard.from_config(NodeConfig('servo', NODE_ID, 'generic_301', canopen.ObjectDictionary()))
    with pytest.raises(ValueError, match='node 5: life time factor must be 1..255, got 0'):
        NodeGuard(NODE_ID, 0.1, 0)
    with pytest.raises(ValueError, match='node 5: guard time must be > 0 s'):
        NodeGuard(NODE_ID, 0.0, 3)


class FakeSdo:
    """The master's write / has_object, recording the writes."""

    def __init__(self, objects: set[tuple[int, int]], failing: tuple[int, int] | None = None) -> None:
        self.objects = objects
        self.failing = failing
        self.writes: list[tuple[int, int, int]] = []

    def has_object(self, index: int, subindex: int) -> bool:
        return (index, subindex) in self.objects

    def write(self, index: int, subindex: int, value: int) -> None:
        if (index, subindex) == self.failing:
            raise RuntimeError(f'SDO abort 0x06090011 on 0x{index:04X}')
        self.writes.append((index, subindex, value))


def test_configure_guarding_clears_the_heartbeat_first() -> None:
    sdo = FakeSdo({(0x1017, 0), (0x100C, 0), (0x100D, 0)})
    configure_guarding(sdo.write, sdo.has_object, 200, 3)
    assert sdo.writes == [(0x1017, 0, 0), (0x100C, 0, 200), (0x100D, 0, 3)]


def test_configure_guarding_skips_a_missing_heartbeat_object() -> None:
    sdo = FakeSdo({(0x100C, 0), (0x100D, 0)})
    configure_guarding(sdo.write, sdo.has_object, 100, 5)
    assert sdo.writes == [(0x100C, 0, 100), (0x100D, 0, 5)]


def test_configure_guarding_lets_sdo_errors_through() -> None:
    sdo = FakeSdo({(0x1017, 0), (0x100C, 0), (0x100D, 0)}, failing=(0x100C, 0))
    with pytest.raises(RuntimeError, match='SDO abort 0x06090011 on 0x100C'):
        configure_guarding(sdo.write, sdo.has_object, 100, 3)
    assert sdo.writes == [(0x1017, 0, 0)]
    with pytest.raises(ValueError, match='guard time must be 1..65535 ms, got 0'):
        configure_guarding(sdo.write, sdo.has_object, 0, 3)
    with pytest.raises(ValueError, match='life time factor must be 1..255, got 256'):
        configure_guarding(sdo.write, sdo.has_object, 100, 256)
