"""Fault catalogue, the bus itself: interface errors on receive and send, error frames,
bus-off and its recovery. The master's bus is a FaultyBus in front of the virtual channel.

Before TappedBus caught them, one exception from ``bus.recv`` ended canopen's Notifier
thread: the master went deaf without a word.
"""
from __future__ import annotations

import threading
import time

from diagnostic_msgs.msg import DiagnosticStatus

from bustools import config_from, demo_data, eventually
from drive_bridge.cia402.statemachine import State
from drive_bridge.master.busload import BusTraffic
from drive_bridge.master.events import EventKind
from drive_bridge.master.master import BusSnapshot
from drive_bridge.ros.diagnostics import bus_status
from faulttools import Events, SentTo, moving, running_faulty, stream_ramp


def test_failing_receives_are_counted_and_the_master_keeps_hearing() -> None:
    with running_faulty(config_from(demo_data())) as (master, _sim, faulty):
        events = Events(master)
        faulty.fail_receives(1)
        eventually(lambda: master.bus.health().recv_errors == 1, 2.0, 'the receive error counted')
        rx = master.traffic.traffic().rx_frames
        eventually(lambda: master.traffic.traffic().rx_frames > rx + 50, 2.0, 'frames still received')
        assert master.network.notifier is not None
        assert all(t.is_alive() for t in master.network.notifier._readers)  # type: ignore[union-attr]
        assert master.sdo_read(2, 0x1018, 2)[1] == 0x402  # SDO answers come in
        health = master.bus.health()
        assert 'receive failed on faulty' in health.last_error and 'interface glitch' in health.last_error
        assert not health.failing and not events.of(EventKind.BUS_ERROR)  # a glitch is counted, not a bus-off
        assert all(n.available for n in master.nodes.values())
        values = {v.key: v.value for v in bus_status(master.snapshot(), 'bridge').values}
        assert values['recv_errors'] == '1' and 'interface glitch' in values['last_bus_error']


def test_error_frames_and_a_failed_send_are_counted_and_nothing_stops() -> None:
    with running_faulty(config_from(demo_data())) as (master, _sim, faulty):
        faulty.error_frames(5)
        eventually(lambda: master.bus.health().error_frames == 5, 2.0, 'five error frames counted')
        faulty.fail_sends(1)
        eventually(lambda: master.bus.health().send_errors == 1, 2.0, 'the send error counted')
        cycles = master.sync.cycles
        time.sleep(0.2)
        assert master.sync.cycles > cycles + 10  # SYNC goes on
        assert all(n.available for n in master.nodes.values())
        master.axes['base_joint'].enable(timeout=2.0)


def test_bus_off_stops_every_stream_reports_once_and_recovers_without_re_enabling() -> None:
    with running_faulty(config_from(demo_data())) as (master, sim, faulty):
        events = Events(master)
        for joint in ('base_joint', 'lift_joint'):
            stream_ramp(master, joint, 0.02)
        assert moving(master, 'base_joint')
        threads = threading.active_count()
        sent = SentTo(master, 2)

        faulty.bus_off(True)
        down = events.wait(EventKind.BUS_ERROR, 3.0)
        assert f'bus {master.config.bus.channel}: ' in down.message
        assert 'bus-off' in down.message and 'every node unavailable, streams stopped' in down.message
        assert master.snapshot().bus_state == 'ERROR'
        assert bus_status(master.snapshot(), 'bridge').message == 'CAN controller ERROR'
        assert not any(a.snapshot().available for a in master.axes.values())
        assert all('bus error' in n.boot_error for n in master.nodes.values())
        time.sleep(0.3)
        assert len(events.of(EventKind.BUS_ERROR)) == 1  # reported once, not per cycle
        assert not events.of(EventKind.HEARTBEAT_LOST)  # a dead bus is not three dead nodes
        assert not events.of(EventKind.ERROR)
        # the drives no longer hear the master's heartbeat: their consumer (0x1016) stops them
        eventually(lambda: sim.drive(2).axis(0).state is not State.OPERATION_ENABLED, 3.0,
                   'drive 2 stopped by its heartbeat consumer')

        faulty.bus_off(False)
        back = events.wait(EventKind.BUS_BACK, 3.0)
        assert 'working again' in back.message and 'axes stay disabled until enabled' in back.message
        master.wait_until_operational(8.0)
        assert master.snapshot().bus_state == 'ACTIVE'
        for joint in ('base_joint', 'lift_joint'):  # never re-enabled by itself
            assert master.axes[joint].snapshot().state is not State.OPERATION_ENABLED
            assert 'enable the axis to move it' in master.axes[joint].snapshot().message
        assert not moving(master, 'base_joint', 0.2)
        assert sent.during(0.2) > 20  # the cycle talks to the drive again (controlwords)
        eventually(lambda: threading.active_count() <= threads, 3.0, 'boot threads gone')
        base = master.axes['base_joint']
        assert base.snapshot().state is State.FAULT  # its heartbeat consumer's fault (EMCY missed while bus-off)
        base.reset_fault(timeout=2.0)
        stream_ramp(master, 'base_joint', 0.02)  # an explicit reset and enable move it again
        assert moving(master, 'base_joint')


def test_an_interface_the_master_opened_is_reopened_while_it_keeps_failing(monkeypatch) -> None:
    import can

    import drive_bridge.master.master as master_module
    from bustools import running
    from drive_bridge.sim.faults import FaultyBus
    opened: list[FaultyBus] = []

    def open_faulty(interface, channel, bitrate=None, **options):  # the interface as python-can opens it
        bus = FaultyBus(can.Bus(interface=interface, channel=channel, receive_own_messages=False))
        opened.append(bus)
        return bus
    monkeypatch.setattr(master_module, 'open_bus', open_faulty)
    with running(config_from(demo_data())) as (master, _sim):
        events = Events(master)
        opened[0].bus_off(True)  # this interface never recovers: only a new one helps
        events.wait(EventKind.BUS_ERROR, 3.0)
        eventually(lambda: len(opened) == 2, 3.0, 'the interface reopened')
        assert master.bus_reopens == 1 and opened[0]._is_shutdown
        events.wait(EventKind.BUS_BACK, 3.0)
        master.wait_until_operational(8.0)


def test_reports_dropped_by_the_bus_process_outbox_warn_on_the_bus_status() -> None:
    snapshot = BusSnapshot(nodes=(), axes=(), sync=None, bus_state='ACTIVE', channel='can0',
                           traffic=BusTraffic(0, 0, 0.0, 0.0))
    fine = bus_status(snapshot, 'bridge', reports_dropped=0)
    assert fine.level == DiagnosticStatus.OK
    assert {v.key: v.value for v in fine.values}['reports_dropped_at_boundary'] == '0'
    status = bus_status(snapshot, 'bridge', reports_dropped=12)
    assert status.level == DiagnosticStatus.WARN
    assert status.message.startswith('12 reports of the bus process dropped (its outbox was full)')
    assert {v.key: v.value for v in status.values}['reports_dropped_at_boundary'] == '12'
    lost = bus_status(snapshot, 'bridge', 'bus process lost: killed', reports_dropped=12)
    assert lost.level == DiagnosticStatus.ERROR  # a lost bus process says so first
