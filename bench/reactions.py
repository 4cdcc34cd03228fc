"""How fast the core reacts and how closely it keeps time: the figures the tests stopped
asserting (they bound them by the nominal time plus a busy machine's slack).

- heartbeat: a drive's heartbeat stops (demo bus, 100 ms producer, consumer limit 300 ms);
  time from the last heartbeat to the master's HEARTBEAT_LOST, beyond the limit;
- guarding: a guarded drive without heartbeat stops answering (guard time 40 ms x life time
  factor 3); time from the silence to GUARDING_LOST, beyond the life time;
- replay: ``replay --onto``'s pacing of a 0.8 s recording of a 4 ms cycle (virtual bus):
  inter-frame error p50/p99/max and how far the last frame drifted from its time, beside a
  naive replay (``time.sleep`` of each recorded interval, then send) in the same run: its
  intervals are each a little long, so its schedule drifts, where ours catches up;
- scan: asking all 127 node ids of an empty bus (0.1 s SDO timeout), beside asking them one
  after the other (computed: 127 x the timeout).

Each row also gives the machine's floor meanwhile (bench/floor.py: a sleep loop's late wake-ups
in another process, on the period of what is measured).

    .venv/bin/python -m bench reactions [--cases heartbeat guarding replay scan] [--repeat 5]
"""
from __future__ import annotations

import argparse
import logging
import statistics
import tempfile
import time
import uuid
from pathlib import Path
from typing import Any

import can
import numpy as np

from bench.cycle import demo_bus
from bench.floor import Floor
from drive_bridge.bag.replay_bus import outgoing, pacing_stats, replay_onto
from drive_bridge.config import parse_bus_config
from drive_bridge.master.events import EventKind
from drive_bridge.master.master import Master
from drive_bridge.sim import SimulatedBus

CASES = ('heartbeat', 'guarding', 'replay', 'scan')
GUARD_MS, LIFE_FACTOR = 40, 3
SCAN_TIMEOUT = 0.1


def _wait_event(events: list[Any], kind: EventKind, timeout: float = 10.0) -> float:
    """The monotonic time at which the first event of ``kind`` arrived (listener-stamped)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        hit = next((t for t, e in list(events) if e.kind is kind), None)
        if hit is not None:
            return hit
        time.sleep(0.002)
    raise RuntimeError(f'no {kind.value} event within {timeout} s')


def _running(config: Any) -> tuple[Master, SimulatedBus, list[Any]]:
    sim = SimulatedBus(config).start()
    master = Master(config)
    events: list[Any] = []
    master.add_event_listener(lambda e: events.append((time.monotonic(), e)))
    master.start()
    master.wait_until_operational(10.0)
    return master, sim, events


def heartbeat_delay() -> float:
    """s from the drive's last heartbeat to HEARTBEAT_LOST, beyond the consumer limit."""
    config = demo_bus()
    master, sim, events = _running(config)
    try:
        limit = master.nodes['lift_drive'].heartbeat_timeout
        last: list[float] = []
        master.add_frame_listener(lambda m: last.append(time.monotonic()) if m.arbitration_id == 0x704 else None)
        time.sleep(0.3)
        sim.drive(4).stop_heartbeat()
        lost = _wait_event(events, EventKind.HEARTBEAT_LOST)
        return lost - max(t for t in last if t < lost) - limit
    finally:
        master.stop()
        sim.stop()


def guarding_delay() -> float:
    """s from the drive's last guarding reply to GUARDING_LOST, beyond the life time."""
    channel = f'bench-guard-{uuid.uuid4().hex[:8]}'
    config = parse_bus_config({
        'bus': {'interface': 'virtual', 'channel': channel}, 'master': {'sync_period': 4000},
        'nodes': {'arm': {'node_id': 6, 'family': 'generic_402', 'guard_time_ms': GUARD_MS,
                          'life_time_factor': LIFE_FACTOR, 'axes': [{'joint': 'arm_joint'}]}},
        'simulation': {'enabled': True, 'nodes': {'arm': {'heartbeat': False}}}}, 'bench', Path.cwd())
    master, sim, events = _running(config)
    try:
        replies: list[float] = []
        master.add_frame_listener(lambda m: replies.append(time.monotonic())
                                  if m.arbitration_id == 0x706 and not m.is_remote_frame else None)
        time.sleep(0.3)
        sim.drive(6).stop_guarding_replies(True)
        lost = _wait_event(events, EventKind.GUARDING_LOST)
        return lost - max(t for t in replies if t < lost) - GUARD_MS * LIFE_FACTOR / 1000
    finally:
        master.stop()
        sim.stop()


def recorded_cycle() -> list[can.Message]:
    """0.8 s of a 4 ms cycle, as the master saw it: SYNC and two RPDOs from the master, TPDOs
    (numbered by cycle) back from nodes 2 and 3 right after SYNC, a heartbeat of node 3 every
    100 ms (test_bag_replay replays the same)."""
    frames = []
    t0 = 1_700_000_000.0

    def frame(t: float, cob_id: int, data: bytes, is_rx: bool) -> can.Message:
        return can.Message(timestamp=t, arbitration_id=cob_id, is_extended_id=False, data=data, is_rx=is_rx)
    for cycle in range(200):
        t = t0 + cycle * 0.004
        frames.append(frame(t, 0x080, b'', False))
        frames += [frame(t + 0.0002 + 0.0001 * i, 0x180 + n, cycle.to_bytes(2, 'little') + bytes(6), True)
                   for i, n in enumerate((2, 3))]
        frames += [frame(t + 0.0031, 0x200 + n, bytes(5), False) for n in (2, 3)]
        if cycle % 25 == 0:
            frames.append(frame(t + 0.0035, 0x703, b'\x05', True))
    return frames


def naive_replay(frames: list[can.Message], bus: can.BusABC) -> Any:
    """What a first attempt does: sleep each recorded interval, then send."""
    sent_at, previous = [], None
    for msg in frames:
        if previous is not None:
            time.sleep(msg.timestamp - previous)
        previous = msg.timestamp
        bus.send(outgoing(msg))
        sent_at.append(time.perf_counter())
    return pacing_stats(np.array([m.timestamp for m in frames]), np.array(sent_at), 1.0, 0, 0, 0.0)


def replay_errors(naive: bool) -> dict[str, float]:
    channel = f'bench-replay-{uuid.uuid4().hex[:8]}'
    frames = recorded_cycle()
    with can.Bus(interface='virtual', channel=channel) as bus, can.Bus(interface='virtual', channel=channel):
        stats = naive_replay(frames, bus) if naive else replay_onto(frames, bus)
    return {'p50': stats.interval_error_p50, 'p99': stats.interval_error_p99, 'max': stats.interval_error_max,
            'drift': stats.duration - stats.recorded_duration}


def scan_seconds() -> float:
    import canopen

    from drive_bridge.bag.scan import scan
    network = canopen.Network()
    network.connect(interface='virtual', channel=f'bench-scan-{uuid.uuid4().hex[:8]}')
    try:
        started = time.monotonic()
        scan(network, range(1, 128), SCAN_TIMEOUT)
        return time.monotonic() - started
    finally:
        network.disconnect()


def _ms(value: float) -> str:
    return f'{value * 1000:.1f}'


def run(case: str, repeat: int, work: Path) -> list[str]:
    """The table rows of one case."""
    period = {'heartbeat': 0.02, 'guarding': 0.02, 'replay': 0.004, 'scan': SCAN_TIMEOUT}[case]
    with Floor(period, 1.0, work) as floor:  # the floor over the first second of the case
        if case == 'replay':
            ours = [replay_errors(False) for _ in range(repeat)]
            naive = [replay_errors(True) for _ in range(repeat)]
        elif case == 'scan':
            took = [scan_seconds() for _ in range(repeat)]
        else:
            delays = [(heartbeat_delay if case == 'heartbeat' else guarding_delay)() for _ in range(repeat)]
    late = f"floor late p99 {_ms(floor.result.get('late_p99', float('nan')))} ms, " \
           f"max {_ms(floor.result.get('late_max', float('nan')))} ms"
    if case == 'replay':
        def cols(runs: list[dict[str, float]]) -> str:
            return ' / '.join(_ms(statistics.median(r[k] for r in runs)) for k in ('p50', 'p99', 'max', 'drift'))
        return [f'| replay | inter-frame error p50 / p99 / max, and the end\'s drift (ms) | {cols(ours)} | '
                f'naive: {cols(naive)} | {late} |']
    if case == 'scan':
        serial = 127 * SCAN_TIMEOUT
        median = statistics.median(took)
        return [f'| scan | 127 ids, s (median of {repeat}) | {median:.2f} | one after the other: {serial:.1f} '
                f'({serial / median:.0f}x) | {late} |']
    what = 'last heartbeat -> lost, beyond the 300 ms limit' if case == 'heartbeat' else \
        f'last reply -> lost, beyond the {GUARD_MS * LIFE_FACTOR} ms life time'
    return [f'| {case} | {what} (ms), median / max of {repeat} | {_ms(statistics.median(delays))} / '
            f'{_ms(max(delays))} | - | {late} |']


def main(argv: list[str] | None = None) -> None:
    logging.disable(logging.CRITICAL)  # the master's own reports of the faults the cases inject
    parser = argparse.ArgumentParser(prog='python -m bench reactions', description=__doc__.split('\n\n')[0])
    parser.add_argument('--cases', nargs='+', choices=CASES, default=list(CASES))
    parser.add_argument('--repeat', type=int, default=5, help='runs per case (default 5)')
    options = parser.parse_args(argv)
    print('| case | figure | bridge | baseline | machine floor meanwhile |\n|---|---|---|---|---|')
    with tempfile.TemporaryDirectory(prefix='bench-reactions-') as tmp:
        for case in options.cases:
            for line in run(case, options.repeat, Path(tmp)):
                print(line, flush=True)


if __name__ == '__main__':
    main()
