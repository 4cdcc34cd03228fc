"""Node guarding end to end, on the bus: the master guards a generic CiA 402 drive that has no
heartbeat objects, reports a repeated toggle as a guarding error, and the drive's own life
guarding reacts when the bridge's remote frames stop."""
from __future__ import annotations

import struct
import time
from typing import Any

from akdtools import Sniffer
from bustools import config_from, eventually, running, unique_channel
from drive_bridge.cia402.statemachine import State
from drive_bridge.master.events import EventKind
from drive_bridge.master.master import Master
from drive_bridge.sim import SimulatedBus
from timingtools import BUSY_SLACK

NODE = 6
GUARD_MS = 40
FACTOR = 3


def guarded_bus(channel: str, reaction: str = 'fault') -> dict[str, Any]:
    return {
        'bus': {'interface': 'virtual', 'channel': channel},
        'master': {'sync_period': 4000},
        'nodes': {'arm': {'node_id': NODE, 'family': 'generic_402', 'guard_time_ms': GUARD_MS,
                          'life_time_factor': FACTOR, 'axes': [{'joint': 'arm_joint'}]}},
        'simulation': {'enabled': True, 'nodes': {'arm': {'heartbeat': False,
                                                          'life_guarding_reaction': reaction}}},
    }


def test_guarded_node_boots_and_rtrs_go_out_at_the_guard_time() -> None:
    channel = unique_channel('guard')
    config = config_from(guarded_bus(channel))
    sniffer = Sniffer(channel)
    try:
        with running(config) as (master, sim):
            assert master.nodes['arm'].available
            mark, started = sniffer.mark, time.monotonic()
            time.sleep(0.4)
            frames = sniffer.frames(0x700 + NODE, after=mark)
            took = time.monotonic() - started
            rtrs = [f for f in frames if f.remote]
            replies = [f for f in frames if not f.remote]
            # never faster than the guard time; at least a few (a busy machine holds the supervisor)
            assert 2 <= len(rtrs) <= 1.5 * took * 1000 / GUARD_MS + 2, \
                f'{len(rtrs)} RTRs in {took:.2f} s at a {GUARD_MS} ms guard time'
            # no heartbeat: every frame the node sends on 0x700 + id answers an RTR, toggling
            assert abs(len(replies) - len(rtrs)) <= 1
            toggles = [f.data[0] & 0x80 for f in replies]
            assert all(a != b for a, b in zip(toggles, toggles[1:])), toggles
            assert all(f.data[0] & 0x7F == 5 for f in replies)  # operational
            master.axes['arm_joint'].enable(timeout=2.0)
    finally:
        sniffer.close()


def test_a_repeated_toggle_is_reported_as_a_guarding_error() -> None:
    config = config_from(guarded_bus(unique_channel('guard')))
    with running(config) as (master, sim):
        sim.drive(NODE).repeat_guarding_toggle(True)
        event = eventually(lambda: next((e for e in master.events if e.kind is EventKind.GUARDING_ERROR), None),
                           2.0, 'guarding error event')
        assert f'node {NODE}' in event.message and 'toggle' in event.message
        assert master.nodes['arm'].snapshot().guarding_toggle_errors >= 1  # also in /diagnostics
        sim.drive(NODE).repeat_guarding_toggle(False)


def test_the_drive_reacts_when_the_bridge_stops_guarding() -> None:
    """The bridge dies (its supervisor, and with it the RTRs, stops) while the axis is enabled:
    the drive's life guarding sends EMCY 0x8130 and faults the axis after the life time."""
    config = config_from(guarded_bus(unique_channel('guard')))
    sim = SimulatedBus(config).start()
    master = Master(config)
    sniffer = Sniffer(config.bus.channel)
    try:
        master.start()
        master.wait_until_operational(10.0)
        master.axes['arm_joint'].enable(timeout=2.0)
        drive = sim.drive(NODE)
        assert drive.axis().state is State.OPERATION_ENABLED
        mark = sniffer.mark
        master._stop.set()  # the supervisor thread ends: no more RTRs, as if the bridge hung
        master._supervisor.join(timeout=2)  # type: ignore[union-attr]
        stopped = time.monotonic()
        life = GUARD_MS * FACTOR / 1000
        eventually(lambda: drive.guarding_lost, life + BUSY_SLACK, 'life guarding on the drive')
        assert time.monotonic() - stopped < life + BUSY_SLACK

        def life_guard_emcy() -> list[Any]:  # the sniffer's thread records the frame after the drive sent it
            return [f for f in sniffer.frames(0x80 + NODE, after=mark)
                    if len(f.data) >= 2 and struct.unpack_from('<H', f.data)[0] == 0x8130]
        eventually(life_guard_emcy, BUSY_SLACK, 'EMCY 0x8130 on the bus')
        eventually(lambda: drive.axis().state is State.FAULT, BUSY_SLACK, 'axis faulted by the life guarding reaction')
    finally:
        sniffer.close()
        master._stop.clear()
        master.stop()
        sim.stop()
