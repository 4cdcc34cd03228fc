"""The boundary between the node process and its bus process, without either process: what a
lane carries (typed records only), its bounds (bytes per message, points per trajectory chunk,
frames per batch, the frame queue, the outbox), the cyclic state's layout, and the outbox's
drop count crossing in it from a bus server on a running Master."""
from __future__ import annotations

import concurrent.futures
import dataclasses
import datetime
import pickle

import can
import pytest

from bustools import config_from, demo_data
from drive_bridge.busproc import cyclic, outbox, wire
from drive_bridge.busproc.client import BusClient
from drive_bridge.busproc.errors import BoundaryError
from drive_bridge.busproc.executor import ExecutorProxy
from drive_bridge.busproc.intents import CHUNK_BYTES, CHUNK_POINTS, Request, Stop, TrajectoryChunk, chunk_points
from drive_bridge.busproc.reports import (
    FRAMES_PER_BATCH,
    AxisStates,
    CommandRefused,
    Frames,
    Reply,
    StopOutcome,
    unpack_frames,
)
from drive_bridge.busproc.server import BusServer
from drive_bridge.cia402.statemachine import State
from drive_bridge.config.source import ConfigSource
from drive_bridge.master.master import Master
from drive_bridge.sim import SimulatedBus
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import MAX_TRAJECTORY_POINTS, Trajectory, TrajectoryPoint
from waittools import wait_for

MAX_JOINT_NAMES = 64  # ros.message_limits: the most joints a trajectory message may name (not imported: no ROS here)


def test_a_record_crosses_whole_and_typed() -> None:
    record = Request(7, Stop(('base_joint', 'lift_joint'), 'quick_stop', 'test'))
    assert wire.decode(wire.encode(record)) == record


@pytest.mark.parametrize('foreign', [datetime.date(2026, 1, 1), wire.encode, pickle.loads])
def test_a_message_naming_anything_but_a_record_is_refused(foreign: object) -> None:
    with pytest.raises(BoundaryError, match='which the boundary does not carry'):
        wire.decode(pickle.dumps(foreign))


def test_garbage_is_a_boundary_error() -> None:
    with pytest.raises(BoundaryError, match='malformed message'):
        wire.decode(b'\x80\x05not a pickle')


def test_a_record_over_the_byte_limit_is_refused_before_it_is_sent() -> None:
    with pytest.raises(BoundaryError, match=f'TrajectoryChunk of [0-9]+ bytes is over .* {wire.MAX_MESSAGE} bytes'):
        wire.encode(chunk(20, CHUNK_POINTS))  # 500 points at 20 joints: ~290 kB


@pytest.mark.parametrize('joints', [1, 4, 8, 12, 16, 20, 32, MAX_JOINT_NAMES])
def test_a_full_trajectory_chunk_fits_one_message_at_any_joint_count(joints: int) -> None:
    points = chunk_points(joints)
    assert 1 <= points <= CHUNK_POINTS
    size = len(wire.encode(chunk(joints, points)))
    assert size <= wire.MAX_MESSAGE
    assert size - len(wire.encode(chunk(joints, 0))) <= CHUNK_BYTES


def test_the_longest_trajectory_on_a_wide_bus_crosses_in_chunks_within_the_limit() -> None:
    sent: list[TrajectoryChunk] = []

    class Lane:  # the client's request lane as far as submitting goes: each chunk encoded, answered
        def call_async(self, body: TrajectoryChunk) -> concurrent.futures.Future[object]:
            assert isinstance(wire.decode(wire.encode(body)), TrajectoryChunk)  # BoundaryError over the limit
            sent.append(body)
            answer: concurrent.futures.Future[object] = concurrent.futures.Future()
            answer.set_result(None)
            return answer
    whole = chunk(20, MAX_TRAJECTORY_POINTS)
    executor = ExecutorProxy(Lane(), 0.1, 0.5)  # type: ignore[arg-type]
    assert executor.submit(Trajectory(whole.joints, whole.points)) is None
    assert [c.chunk for c in sent] == list(range(len(sent))) and {c.chunks for c in sent} == {len(sent)}
    assert tuple(p for c in sent for p in c.points) == whole.points
    assert max(len(c.points) for c in sent) == chunk_points(20) < CHUNK_POINTS


def test_the_cyclic_state_round_trips_and_a_wrong_size_is_refused() -> None:
    joints = [(True, 0.5, -1.25, 0.01, 1.7e9), (False, 0.0, 0.0, 0.0, 0.0)]
    data = cyclic.pack(2**32 + 5, 0.002, 3, 1, joints, reports_dropped=42)
    assert len(data) == cyclic.size(2)
    state = cyclic.unpack(data, 2)
    assert (state.sequence, state.lag, state.stalls, state.dropped, state.reports_dropped, state.joints) == (
        5, 0.002, 3, 1, 42, tuple(joints))
    with pytest.raises(ValueError, match='expected'):
        cyclic.unpack(data, 3)


def test_frames_cross_in_bounded_batches_and_a_full_queue_counts_its_drops(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(outbox, 'MAX_FRAMES', FRAMES_PER_BATCH + 10)
    node_end, bus_end = wire.lane_pair()
    box = outbox.Outbox(wire.Lane(bus_end), lambda reason: None)
    reader = wire.Lane(node_end)
    try:
        box.on_frame(can.Message(arbitration_id=0x80))  # not forwarded: nobody records
        assert not box.frames
        box.forward_frames = True
        for k in range(FRAMES_PER_BATCH + 15):  # the sender not started: the queue fills
            box.on_frame(can.Message(timestamp=k, arbitration_id=0x180 + k % 4, data=k.to_bytes(4, 'little')))
        assert len(box.frames) == FRAMES_PER_BATCH + 10 and box.dropped_frames == 5
        box.start()
        batches = []
        while sum(b.count for b in batches) < FRAMES_PER_BATCH + 10:
            record = reader.recv()
            if isinstance(record, Frames):
                batches.append(record)
        assert [b.count for b in batches] == [FRAMES_PER_BATCH, 10]
        assert all(b.dropped == 5 for b in batches)  # the count travels with every batch
        first = unpack_frames(batches[0].data)[0]
        assert (first[1], first[6]) == (0x180, (0).to_bytes(4, 'little'))
    finally:
        box.stop()
        reader.close()
        bus_end.close()


def test_a_full_outbox_drops_and_counts_reports_but_answers_still_go(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(outbox, 'MAX_RECORDS', 5)
    node_end, bus_end = wire.lane_pair()
    box = outbox.Outbox(wire.Lane(bus_end), lambda reason: None)
    reader = wire.Lane(node_end)
    try:
        for k in range(8):  # the sender not started: the queue fills
            box.put(CommandRefused('~/commands', f'refused {k}'))
        assert len(box.records) == 5 and box.dropped_records == 3
        box.put(Reply(7, None))  # an answer is never dropped: its request waits for it
        assert len(box.records) == 6 and box.dropped_records == 3
        box.start()
        received = [reader.recv() for _ in range(6)]
        assert [r.reason for r in received[:5] if isinstance(r, CommandRefused)] == [f'refused {k}' for k in range(5)]
        assert received[5] == Reply(7, None)
    finally:
        box.stop()
        reader.close()
        bus_end.close()


def test_the_outbox_drop_count_reaches_the_node_in_every_cyclic_state(monkeypatch: pytest.MonkeyPatch) -> None:
    """A bus server on a running Master, as the bus process runs it: with an outbox that takes
    nothing, the Master's own reports (its boot events) are dropped, and each cyclic state the
    node side reads says how many."""
    monkeypatch.setattr(outbox, 'MAX_RECORDS', 0)
    config = config_from(demo_data())
    pairs = [wire.lane_pair() for _ in range(3)]
    node_stop, node_requests, node_state = (wire.Lane(node) for node, _ in pairs)
    sim = SimulatedBus(config).start()
    master = Master(config)
    server = BusServer(master, *(wire.Lane(bus) for _, bus in pairs), on_lost=lambda reason: None,
                       on_shutdown=lambda reason: None)
    try:
        master.start()
        server.start(TrajectoryExecutor(master.axes, cycle_period=config.master.cycle_period))
        master.wait_until_operational(10.0)
        wait_for(lambda: server.outbox.dropped_records > 0, 5, 'the boot events dropped by the full outbox')
        joints = len(master.axes)
        states: list[cyclic.CyclicState] = []
        while not states or states[-1].reports_dropped == 0:  # the lane holds every state since the start
            data = node_state.recv_bytes()
            assert data is not None and len(states) < 100_000
            states.append(cyclic.unpack(data, joints))
        counts = [s.reports_dropped for s in states]
        assert counts == sorted(counts)  # a running count
        assert 0 < counts[-1] <= server.outbox.dropped_records
    finally:
        server.close()
        master.stop()
        sim.stop()
        for lane in (node_stop, node_requests, node_state):
            lane.close()


def chunk(joints: int, points: int) -> TrajectoryChunk:
    """A chunk of ``points`` points of positions, velocities and accelerations on ``joints``
    joints with long names, values that pickle at full size."""
    names = tuple(f'a_rather_long_joint_name_of_a_wide_bus_{j:03d}' for j in range(joints))
    return TrajectoryChunk(1, 0, 1, names, tuple(
        TrajectoryPoint(0.123456789 * (i + 1), tuple(0.1234567 * j + i for j in range(joints)),
                        tuple(0.3456789 * j + i for j in range(joints)),
                        tuple(-0.7654321 * j - i for j in range(joints)))
        for i in range(points)), 1.7e9, 'joint_trajectory')


def test_a_report_taken_before_a_stop_answer_never_undoes_it() -> None:
    """Reports (request lane) and stop answers (stop lane) are read by different threads: a
    joint's state reported before a quick stop, read after the stop's answer, must not show
    the joint enabled again (seen once on a busy machine: ``~/quick_stop`` answered, and the
    node still said OPERATION_ENABLED)."""
    config = config_from(demo_data())
    client = BusClient(config, ConfigSource(text='unused'))
    (stop_node, stop_bus), (request_node, request_bus), (state_node, state_bus) = (wire.lane_pair() for _ in range(3))
    client.stop_lane, client.request_lane, client.state_lane = (
        wire.Lane(end) for end in (stop_node, request_node, state_node))
    bus_stops, bus_requests = wire.Lane(stop_bus), wire.Lane(request_bus)
    joint = 'base_joint'
    proxy = client.axes[joint]

    def states(state: State, taken: float) -> AxisStates:
        snapshot = dataclasses.replace(proxy.snapshot(), state=state, available=True)
        return AxisStates((snapshot,), ('position',), (None,), taken)

    try:
        client.start_readers()
        answer = client.stop(Stop((joint,), 'quick_stop'))
        request = bus_stops.recv()
        assert isinstance(request, Request)
        bus_stops.send(Reply(request.id, StopOutcome(((joint, ''),), states(State.QUICK_STOP_ACTIVE, 2.0))))
        answer.result(10)
        assert proxy.state is State.QUICK_STOP_ACTIVE
        refused: list[str] = []
        client.add_refusal_listener(lambda topic, reason: refused.append(reason))
        bus_requests.send(states(State.OPERATION_ENABLED, 1.0))  # taken before the stop, read after its answer
        bus_requests.send(CommandRefused('~/commands', 'a marker'))  # read after it: the report was handled
        wait_for(lambda: refused, 10, 'the marker after the old report')
        assert proxy.state is State.QUICK_STOP_ACTIVE, 'an older report undid the quick stop'
        bus_requests.send(states(State.SWITCH_ON_DISABLED, 3.0))  # a newer one is applied
        wait_for(lambda: proxy.state is State.SWITCH_ON_DISABLED, 10, 'the newer report applied')
    finally:
        for lane in (bus_stops, bus_requests):
            lane.close()
        state_bus.close()
