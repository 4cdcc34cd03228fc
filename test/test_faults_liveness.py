"""Fault catalogue, one node going quiet while the others move: its TPDOs stop while its
heartbeat goes on (the per-TPDO freshness watchdog), or its heartbeat stops mid-motion.
Only that node's joint stops; the other joints keep streaming."""
from __future__ import annotations

import time

from bustools import config_from, demo_data, eventually, running
from drive_bridge.cia402.statemachine import State
from drive_bridge.master.events import EventKind
from drive_bridge.master.freshness import FRESHNESS_MIN, PdoFreshness
from drive_bridge.master.pdo import PdoLayout
from drive_bridge.model import PdoConfig
from drive_bridge.ros.diagnostics import axis_status, node_status
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint
from faulttools import Events, SentTo, moving, stream_ramp
from timingtools import BUSY_SLACK, CycleWatch

CW_HALT = 1 << 8
OTHERS = ('base_joint', 'shoulder_joint')


def lift_trajectory(master, seconds: float = 4.0) -> Trajectory:
    p0 = master.axes['lift_joint'].commanded_position()
    return Trajectory(('lift_joint',), (TrajectoryPoint(seconds, (p0 + 0.05 * seconds,)),))


def test_a_node_whose_tpdos_stop_is_stale_its_joint_held_and_the_others_keep_streaming() -> None:
    with running(config_from(demo_data())) as (master, sim):
        events = Events(master)
        executor = TrajectoryExecutor(master.axes, cycle_period=master.config.master.cycle_period)
        master.add_cycle_listener(executor.check)
        for joint in OTHERS:
            stream_ramp(master, joint, 0.02)
        lift = master.axes['lift_joint']
        lift.enable(timeout=2.0)
        lift.set_mode('csp')
        handle = executor.submit(lift_trajectory(master))
        assert handle is not None
        assert moving(master, 'lift_joint')

        sim.drive(4).stop_tpdos()
        stopped = time.monotonic()
        stale = events.wait(EventKind.PDO_STALE, 3.0)
        assert time.monotonic() - stopped < FRESHNESS_MIN + BUSY_SLACK
        assert stale.node_id == 4
        assert stale.message.startswith('node 4 (lift_drive): TPDO1 0x184 stale: none for ')
        assert 'expected every 4 ms' in stale.message and 'while its heartbeat continues' in stale.message
        assert 'joint(s) lift_joint held (HALT), streams aborted' in stale.message
        assert not events.of(EventKind.HEARTBEAT_LOST)
        # its stream aborts with the cause; its axis state says why it is unavailable
        assert handle.wait(2.0) and handle.state == 'aborted'
        assert 'joint lift_joint left operation enabled' in handle.reason and 'TPDO1 0x184 stale' in handle.reason
        snapshot = lift.snapshot()
        assert not snapshot.available and snapshot.halted and 'TPDO1 0x184 stale' in snapshot.message
        assert 'TPDO1 0x184 stale' in axis_status(snapshot).values[-1].value
        node = next(n for n in master.snapshot().nodes if n.node_id == 4)
        assert node.boot_state.value == 'stale' and 'TPDO1 0x184 stale' in node_status(node).message
        # on the bus: the drive is still told to hold (HALT bit in its controlword), and does
        assert SentTo(master, 4).during(0.2) > 10
        assert sim.drive(4).axis(0).controlword & CW_HALT
        position = sim.drive(4).axis(0).position
        time.sleep(0.3)
        assert abs(sim.drive(4).axis(0).position - position) < 200  # counts (1 µm each): at rest
        for joint in OTHERS:
            assert master.axes[joint].snapshot().available and moving(master, joint)

        sim.drive(4).stop_tpdos(False)
        fresh = events.wait(EventKind.PDO_FRESH, 3.0)
        assert 'node 4 (lift_drive): TPDOs fresh again' in fresh.message
        eventually(lambda: lift.snapshot().available, 2.0, 'lift available again')
        assert lift.snapshot().halted  # held until resumed
        assert len(events.of(EventKind.PDO_STALE)) == 1


def test_heartbeat_lost_mid_motion_stops_only_that_joint() -> None:
    with running(config_from(demo_data())) as (master, sim):
        events = Events(master)
        for joint in (*OTHERS, 'lift_joint'):
            stream_ramp(master, joint, 0.02)
        assert moving(master, 'lift_joint')
        sent = SentTo(master, 4)

        sim.drive(4).stop_heartbeat()
        lost = events.wait(EventKind.HEARTBEAT_LOST, 3.0)
        assert lost.message.startswith('node 4 (lift_drive): heartbeat lost, none for ')
        assert 'its axes are unavailable' in lost.message
        snapshot = master.axes['lift_joint'].snapshot()
        assert not snapshot.available and snapshot.message.startswith('heartbeat lost: none for ')
        assert sent.during(0.2) == 0  # nothing more is sent to a node that may be gone
        watch = CycleWatch(master)
        for joint in OTHERS:  # the others keep streaming: the cycle goes on (its skipped share
            # beside the machine's floor: `python -m bench cycle --cases lost`)
            assert master.axes[joint].snapshot().available and moving(master, joint)
        assert watch.cycles > 0.1 * 0.6 / master.config.master.sync_period, watch  # 10 % of the grid
        assert len(events.of(EventKind.HEARTBEAT_LOST)) == 1 and events.all[-1].node_id == 4


def test_guarding_lost_mid_motion_stops_only_that_joint() -> None:
    data = demo_data()
    data['nodes']['lift_drive'].update(guard_time_ms=40, life_time_factor=3, heartbeat_producer=0)
    data['simulation'] = {'enabled': True, 'nodes': {'lift_drive': {'heartbeat': False}}}
    with running(config_from(data)) as (master, sim):
        assert master.nodes['lift_drive'].liveness.value == 'node guarding'
        events = Events(master)
        for joint in (*OTHERS, 'lift_joint'):
            stream_ramp(master, joint, 0.02)
        sent = SentTo(master, 4)
        sim.drive(4).stop_guarding_replies()
        lost = events.wait(EventKind.GUARDING_LOST, 3.0)
        assert lost.node_id == 4 and '(lift_drive); its axes are unavailable' in lost.message
        assert 'node 4' in lost.message
        assert not master.axes['lift_joint'].snapshot().available
        assert 'node guarding lost' in master.axes['lift_joint'].snapshot().message
        assert sent.during(0.2) == 0
        for joint in OTHERS:
            assert master.axes[joint].snapshot().available and moving(master, joint)
        sim.drive(4).stop_guarding_replies(False)
        events.wait(EventKind.GUARDING_BACK, 3.0)
        master.wait_until_operational(5.0)
        # still enabled on the drive (its life guarding did not trip): the bridge disables it
        eventually(lambda: master.axes['lift_joint'].snapshot().state is not State.OPERATION_ENABLED, 2.0,
                   'lift_joint disabled after it answers again')
        assert 'enable the axis to move it' in master.axes['lift_joint'].snapshot().message


def test_freshness_counts_syncs_so_a_stalled_master_blames_no_drive() -> None:
    sync_tpdo = PdoLayout(PdoConfig(number=1, cob_id=0x184, transmission=2), 0, ())
    timer_tpdo = PdoLayout(PdoConfig(number=2, cob_id=0x284, transmission=255, event_timer=10), 0, ())
    on_change = PdoLayout(PdoConfig(number=3, cob_id=0x384, transmission=255), 0, ())
    counts = {0x184: 0, 0x284: 0, 0x384: 0}
    freshness = PdoFreshness({0x184: sync_tpdo, 0x284: timer_tpdo, 0x384: on_change}, counts, 0.004)
    assert freshness.watched == (0x184, 0x284)  # a TPDO sent only on change has no deadline
    assert freshness.poll(100.0, 1000) == []  # not armed: the node is not started
    freshness.arm(0.0, 0)
    counts[0x284] = 1
    assert freshness.poll(0.2, 10) == []
    # 10 s on the clock but only 60 SYNCs sent: the master stalled, the synchronous TPDO is not
    # blamed; the event-timer TPDO is judged by the clock alone
    assert [s.number for s in freshness.poll(10.0, 60)] == [2]
    stale = freshness.poll(10.0, 100)
    assert [str(s) for s in stale] == ['TPDO1 0x184 stale: none for 10000 ms (expected every 8 ms, limit 400 ms)',
                                       'TPDO2 0x284 stale: none for 9800 ms (expected every 10 ms, limit 500 ms)']
    counts[0x184] += 1
    counts[0x284] += 1
    assert freshness.poll(10.4, 201) == []


def test_a_node_stopped_by_nmt_is_not_stale_and_a_stale_node_reset_to_pre_operational_is_configured_again() -> None:
    with running(config_from(demo_data())) as (master, sim):
        events = Events(master)
        lift = master.axes['lift_joint']
        master.nmt(0x02, 4)  # NMT stop: no TPDO by right, the heartbeat goes on
        eventually(lambda: master.nodes['lift_drive'].nmt_state.value != 'operational', 2.0, 'stopped')
        time.sleep(FRESHNESS_MIN + 0.4)
        master.nmt(0x01, 4)
        eventually(lambda: lift.snapshot().available, 2.0, 'lift available after NMT start')
        time.sleep(FRESHNESS_MIN + 0.2)
        assert not events.of(EventKind.PDO_STALE) and not events.of(EventKind.PDO_FRESH)

        sim.drive(4).stop_tpdos()
        events.wait(EventKind.PDO_STALE, 3.0)
        booted = len(events.of(EventKind.BOOTED))
        master.nmt(0x80, 4)  # to pre-operational: the stale node must be configured again
        eventually(lambda: sim.drive(4).nmt_state == 'PRE-OPERATIONAL', 2.0, 'drive pre-operational')
        sim.drive(4).stop_tpdos(False)
        eventually(lambda: len(events.of(EventKind.BOOTED)) > booted, 5.0, 'lift_drive configured again')
        eventually(lambda: lift.snapshot().available, 2.0, 'lift available again')
        assert not events.of(EventKind.PDO_FRESH)


def test_a_dead_node_is_explained_by_its_heartbeat_not_by_its_tpdos() -> None:
    with running(config_from(demo_data())) as (master, sim):
        events = Events(master)
        sim.drive(4).mute()
        events.wait(EventKind.HEARTBEAT_LOST, 3.0)
        time.sleep(0.3)
        assert not events.of(EventKind.PDO_STALE)


def test_a_dead_guarded_node_is_guarding_lost_and_configured_again_when_it_answers() -> None:
    data = demo_data()
    data['nodes']['lift_drive'].update(guard_time_ms=100, life_time_factor=3, heartbeat_producer=0)
    data['simulation'] = {'enabled': True, 'nodes': {'lift_drive': {'heartbeat': False}}}
    with running(config_from(data)) as (master, sim):
        events = Events(master)
        booted = len(events.of(EventKind.BOOTED))
        sim.drive(4).mute()
        events.wait(EventKind.GUARDING_LOST, 3.0)  # also when its TPDOs were found stale first
        sim.drive(4).mute(False)
        events.wait(EventKind.GUARDING_BACK, 3.0)
        eventually(lambda: len(events.of(EventKind.BOOTED)) > booted, 5.0, 'lift_drive configured again')


def test_a_stale_node_is_never_re_enabled_by_the_bridge() -> None:
    with running(config_from(demo_data())) as (master, sim):
        events = Events(master)
        lift = master.axes['lift_joint']
        lift.enable(timeout=2.0)
        sim.drive(4).stop_tpdos()
        events.wait(EventKind.PDO_STALE, 3.0)
        # its real state is unknown: a controlword that cannot raise one (quick stop, bit 2 low)
        eventually(lambda: sim.drive(4).axis(0).controlword & 0x0F == 0x02, 1.0, 'quick stop sent')
        eventually(lambda: sim.drive(4).axis(0).statusword & 0x6F != 0x27, 2.0, 'drive left operation enabled')
        sim.drive(4).stop_tpdos(False)
        events.wait(EventKind.PDO_FRESH, 3.0)
        eventually(lambda: lift.snapshot().available, 2.0, 'lift available')
        time.sleep(0.3)
        assert lift.snapshot().state is not State.OPERATION_ENABLED  # the enable intent was dropped
        lift.halt(False)
        lift.enable(timeout=2.0)  # an explicit enable moves it again


def test_an_error_in_one_supervision_step_is_reported_and_supervision_goes_on() -> None:
    with running(config_from(demo_data())) as (master, sim):
        events = Events(master)
        lift = master.axes['lift_joint']
        reset = lift.on_node_reset
        calls = []

        def failing_once() -> None:  # a family driver's hook that raises
            calls.append(1)
            if len(calls) == 1:
                raise RuntimeError('broken hook')
            reset()
        lift.on_node_reset = failing_once
        sim.drive(4).stop_tpdos()
        events.wait(EventKind.PDO_STALE, 3.0)
        booted = len(events.of(EventKind.BOOTED))
        master.nmt(0x80, 4)  # the stale node leaves OPERATIONAL: its axes are reset (and the hook raises)
        eventually(lambda: sim.drive(4).nmt_state == 'PRE-OPERATIONAL', 2.0, 'drive pre-operational')
        sim.drive(4).stop_tpdos(False)
        error = events.wait(EventKind.ERROR, 3.0)
        assert error.message.startswith("node 4 (lift_drive): supervision step failed: RuntimeError('broken hook')")
        eventually(lambda: len(events.of(EventKind.BOOTED)) > booted, 5.0, 'lift_drive configured again')
