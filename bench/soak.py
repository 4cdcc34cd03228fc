"""Soak benchmark: 4 axes streaming trajectories for minutes while faults from the fault
catalogue are injected at random every few seconds (each fault once per pass through the
catalogue, in a random order, on a random node).

Each round: a few seconds of motion, one fault injected, the bridge's report of it awaited
(the event or counter that names node and cause), the fault cleared, and service awaited
(every node operational, every axis enabled again by the "operator" of this benchmark:
reset fault, resume, enable; the bridge itself never re-enables). At the end: faults
injected / detected with the right message / recovered, frames lost (frames the simulators
and the flood sender put on the bus, minus those missed while bus-off, against the frames
the master's tap received), RSS and thread count at start and end.

Baseline in the same run: a plain canopen Network (python-can Notifier, no TappedBus) on
the same faulty bus, given one receive error: how many frames it hears afterwards.

    .venv/bin/python -m bench soak [--minutes 10] [--seed 1]
"""
from __future__ import annotations

import argparse
import logging
import random
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import can
import canopen
import psutil
import yaml

from drive_bridge.cia402.statemachine import State
from drive_bridge.config import parse_bus_config
from drive_bridge.master.events import BusEvent, EventKind
from drive_bridge.master.master import Master
from drive_bridge.model import BusConfig
from drive_bridge.resources import shipped_config
from drive_bridge.sim import SimulatedBus
from drive_bridge.sim.faults import FaultyBus
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint

DETECT_TIMEOUT = 3.0  # s for the bridge to report a fault
RECOVER_TIMEOUT = 15.0  # s for the bus to be back in service after the fault is cleared
MOVE_SECONDS = (1.5, 4.0)  # motion between two faults (uniform)
FLOOD_FRAMES = 400


@dataclass
class Tally:
    injected: int = 0
    detected: int = 0
    recovered: int = 0
    detect_times: list[float] = field(default_factory=list)
    misses: list[str] = field(default_factory=list)


@dataclass
class Soak:
    """The bus under test and the operator's view of it."""

    config: BusConfig
    sim: SimulatedBus
    faulty: FaultyBus
    master: Master
    executor: TrajectoryExecutor
    rng: random.Random
    events: list[BusEvent] = field(default_factory=list)
    emcys: list[tuple[int, int]] = field(default_factory=list)  # (node id, code)
    rogue_sent: int = 0
    error_frames: int = 0

    def since(self, mark: int, kind: EventKind, node_id: int = 0, text: str = '') -> bool:
        return any(e.kind is kind and (not node_id or e.node_id == node_id) and text in e.message
                   for e in self.events[mark:])

    # -- the operator ------------------------------------------------------------------------
    def tend(self) -> None:
        """Bring every available axis back to streaming (reset, resume, enable, CSP) and keep
        a trajectory running on all four."""
        for axis in self.master.axes.values():
            if not axis.available:
                continue
            try:
                snapshot = axis.snapshot()
                if snapshot.state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
                    axis.reset_fault(timeout=1.0)
                if snapshot.halted:
                    axis.halt(False)
                if axis.snapshot().state is not State.OPERATION_ENABLED:
                    axis.enable(timeout=1.0)
                    axis.set_mode('csp', timeout=1.0)
            except Exception:  # the next fault may hit while tending: try again next time
                continue
        if not self.executor.active():
            self.submit()

    def submit(self) -> None:
        joints = tuple(self.master.axes)
        targets = []
        for joint in joints:
            limits = self.master.axes[joint].config.limits
            lo, hi = limits.min_position or -1.0, limits.max_position or 1.0
            middle, span = (lo + hi) / 2, (hi - lo) * 0.2
            targets.append(middle + self.rng.uniform(-span, span))
        try:
            self.executor.submit(Trajectory(joints, (TrajectoryPoint(2.5, tuple(targets)),)), 'soak')
        except TrajectoryError:
            pass  # an axis not yet enabled: next time

    def in_service(self) -> bool:
        return all(n.available for n in self.master.nodes.values()) and all(
            a.snapshot().state is State.OPERATION_ENABLED for a in self.master.axes.values())

    def run_for(self, seconds: float, until: Callable[[], bool] | None = None) -> bool:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if until is not None and until():
                return True
            self.tend()
            time.sleep(0.05)
        return until is not None and until()

    # -- the flood sender -------------------------------------------------------------------
    def rogue(self, frames: list[can.Message]) -> None:
        bus = can.Bus(interface='virtual', channel=self.config.bus.channel)
        try:
            for msg in frames:
                bus.send(msg)
                self.rogue_sent += 1
        finally:
            bus.shutdown()


Fault = Callable[[Soak, int], tuple[Callable[[], bool], Callable[[], None]]]  # -> (detected?, clear)


def heartbeat_stop(s: Soak, node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    mark = len(s.events)
    s.sim.drive(node).stop_heartbeat()
    return (lambda: s.since(mark, EventKind.HEARTBEAT_LOST, node, 'heartbeat lost'),
            s.sim.drive(node).start_heartbeat)


def tpdo_stop(s: Soak, node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    mark = len(s.events)
    s.sim.drive(node).stop_tpdos()
    return (lambda: s.since(mark, EventKind.PDO_STALE, node, 'stale: none for'),
            lambda: s.sim.drive(node).stop_tpdos(False))


def drive_fault(s: Soak, node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    mark = len(s.emcys)
    s.sim.drive(node).inject_fault(0x2310)  # type: ignore[attr-defined]
    return (lambda: (node, 0x2310) in s.emcys[mark:]), lambda: None


def reboot(s: Soak, node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    mark = len(s.events)
    drive = s.sim.drive(node)
    drive.power_off()
    drive.power_on()
    return (lambda: s.since(mark, EventKind.UNEXPECTED_BOOT, node, 'sent a boot-up message')
            or s.since(mark, EventKind.HEARTBEAT_LOST, node)), lambda: None


def bus_off(s: Soak, _node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    mark = len(s.events)
    s.faulty.bus_off(True)
    return (lambda: s.since(mark, EventKind.BUS_ERROR, 0, 'bus-off')), lambda: s.faulty.bus_off(False)


def receive_glitch(s: Soak, _node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    assert s.master.bus is not None
    before = s.master.bus.health().recv_errors
    s.faulty.fail_receives(1)
    bus = s.master.bus
    return (lambda: bus.health().recv_errors > before and 'interface glitch' in bus.health().last_error), \
        lambda: None


def error_frames(s: Soak, _node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    assert s.master.bus is not None
    bus = s.master.bus
    before = bus.health().error_frames
    s.faulty.error_frames(3)
    s.error_frames += 3
    return (lambda: bus.health().error_frames >= before + 3), lambda: None


def emcy_flood(s: Soak, node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    runtime = s.master.node_by_id(node)
    assert runtime is not None
    before = runtime.emcy_limit.suppressed
    s.rogue([can.Message(arbitration_id=0x80 + node, data=b'\x00\x10\x01\x00\x00\x00\x00\x00',
                         is_extended_id=False)] * FLOOD_FRAMES)
    return (lambda: runtime.emcy_limit.suppressed > before), lambda: None


def unknown_flood(s: Soak, _node: int) -> tuple[Callable[[], bool], Callable[[], None]]:
    counter = s.master.unknown_frames
    before = counter.by_id.get(0x7F0, 0)
    s.rogue([can.Message(arbitration_id=0x7F0, data=b'\x01' * 8, is_extended_id=False)] * FLOOD_FRAMES)
    return (lambda: counter.by_id.get(0x7F0, 0) >= before + FLOOD_FRAMES), lambda: None


CATALOGUE: dict[str, Fault] = {
    'heartbeat stopped': heartbeat_stop, 'TPDOs stopped': tpdo_stop, 'drive fault (EMCY)': drive_fault,
    'drive reboot': reboot, 'bus-off': bus_off, 'receive error': receive_glitch,
    'error frames': error_frames, 'EMCY flood': emcy_flood, 'unknown-id flood': unknown_flood,
}


def naive_baseline(config: BusConfig) -> tuple[int, int]:
    """(frames heard in 0.5 s before, in 0.5 s after) one receive error, by canopen's own
    Network, of a frame sent every 5 ms."""
    faulty = FaultyBus(can.Bus(interface='virtual', channel=config.bus.channel, receive_own_messages=False))
    sender = can.Bus(interface='virtual', channel=config.bus.channel)
    task = sender.send_periodic(can.Message(arbitration_id=0x7F0, data=b'\x01', is_extended_id=False), 0.005)
    network = canopen.Network(faulty)
    heard = [0]
    network.connect()
    assert network.notifier is not None
    network.notifier.add_listener(lambda _msg: heard.__setitem__(0, heard[0] + 1))
    hook, threading.excepthook = threading.excepthook, lambda _args: None  # its death is the point
    try:
        time.sleep(0.5)
        before = heard[0]
        faulty.fail_receives(1)
        time.sleep(0.1)
        mark = heard[0]
        time.sleep(0.5)
        return before, heard[0] - mark
    finally:
        threading.excepthook = hook
        task.stop()
        sender.shutdown()
        try:
            network.disconnect()
        except Exception:  # the dead Notifier re-raises its exception on stop
            pass


def soak_config(name: str = 'soak') -> BusConfig:
    demo = shipped_config('demo.yaml')
    data = yaml.safe_load(demo.read_text())
    data['bus']['channel'] = f'{name}-{time.monotonic_ns()}'
    return parse_bus_config(data, 'soak (demo config)', demo.parent)


@dataclass
class SoakResult:
    seconds: float
    tallies: dict[str, Tally]
    frames_expected: int
    frames_received: int
    missed_bus_off: int
    rss_start: int
    rss_end: int
    threads_start: int
    threads_end: int
    naive: tuple[int, int]

    @property
    def frames_lost(self) -> int:
        return self.frames_expected - self.frames_received


def run(seconds: float, seed: int = 1, log: Callable[[str], None] = print) -> SoakResult:
    """Soak for ``seconds``; faults from CATALOGUE at random between motion."""
    config = soak_config()
    rng = random.Random(seed)
    # the master's bus first: it queues every frame the drives send from their boot-up on
    faulty = FaultyBus(can.Bus(interface='virtual', channel=config.bus.channel, receive_own_messages=False))
    sim = SimulatedBus(config).start()
    master = Master(config, bus=faulty)
    executor = TrajectoryExecutor(master.axes, cycle_period=config.master.cycle_period)
    soak = Soak(config, sim, faulty, master, executor, rng)
    master.add_event_listener(soak.events.append)
    master.add_emcy_listener(lambda e: soak.emcys.append((e.node_id, e.code)))
    master.add_cycle_listener(executor.check)
    master.add_emcy_listener(executor.on_emcy, safety=True)
    tallies = {name: Tally() for name in CATALOGUE}
    process = psutil.Process()
    try:
        master.start()
        master.wait_until_operational(10.0)
        soak.run_for(3.0, soak.in_service)
        rss_start, threads_start = process.memory_info().rss, threading.active_count()
        node_ids = [n.node_id for n in config.nodes]
        end = time.monotonic() + seconds
        deck: list[str] = []
        while time.monotonic() < end:
            soak.run_for(rng.uniform(*MOVE_SECONDS))
            if not deck:  # every fault once per pass, in a random order: even a short run sees them all
                deck = rng.sample(list(CATALOGUE), len(CATALOGUE))
            name = deck.pop()
            node = rng.choice(node_ids)
            tally = tallies[name]
            tally.injected += 1
            started = time.monotonic()
            detected, clear = CATALOGUE[name](soak, node)
            found = soak.run_for(DETECT_TIMEOUT, detected)
            if found:
                tally.detected += 1
                tally.detect_times.append(time.monotonic() - started)
            else:
                tally.misses.append(f'{name} on node {node}: not reported within {DETECT_TIMEOUT:g} s')
            time.sleep(0.3 if name == 'bus-off' else 0.0)
            clear()
            if soak.run_for(RECOVER_TIMEOUT, soak.in_service):
                tally.recovered += 1
            else:
                tally.misses.append(f'{name} on node {node}: not back in service within {RECOVER_TIMEOUT:g} s')
            log(f'{time.monotonic() - end + seconds:7.1f} s  {name:<20} node {node}  '
                f'{"detected" if found else "MISSED"}')
        soak.run_for(1.0)
        threads_end, rss_end = threading.active_count(), process.memory_info().rss
        # quiet the drives, let the last frames arrive, then count
        sim.stop()
        time.sleep(0.5)
        sent = sum(d.frames_sent for d in sim.drives.values())
        received = master.traffic.traffic().rx_frames
    finally:
        master.stop()
        sim.stop()
    naive = naive_baseline(soak_config('soak-naive'))
    return SoakResult(seconds, tallies, sent + soak.rogue_sent + soak.error_frames - faulty.missed, received,
                      faulty.missed, rss_start, rss_end, threads_start, threads_end, naive)


def report(result: SoakResult) -> None:
    print(f'\nsoak: {result.seconds / 60:.1f} min, 4 axes streaming, faults at random\n')
    print(f'{"fault":<20} {"injected":>8} {"detected":>8} {"recovered":>9} {"detect median":>14}')
    total = Tally()
    for name, tally in result.tallies.items():
        times = sorted(tally.detect_times)
        median = f'{times[len(times) // 2] * 1000:.0f} ms' if times else '-'
        print(f'{name:<20} {tally.injected:>8} {tally.detected:>8} {tally.recovered:>9} {median:>14}')
        total.injected += tally.injected
        total.detected += tally.detected
        total.recovered += tally.recovered
    print(f'{"all":<20} {total.injected:>8} {total.detected:>8} {total.recovered:>9}')
    for miss in (m for t in result.tallies.values() for m in t.misses):
        print(f'  ! {miss}')
    print(f'\nframes: {result.frames_expected} expected at the master (sent by the simulators and the flood '
          f'sender, minus {result.missed_bus_off} missed while bus-off), {result.frames_received} received: '
          f'{result.frames_lost} lost')
    mib = 1024 * 1024
    print(f'RSS: {result.rss_start / mib:.1f} MiB at start, {result.rss_end / mib:.1f} MiB at end '
          f'({(result.rss_end - result.rss_start) / mib:+.1f} MiB)')
    print(f'threads: {result.threads_start} at start, {result.threads_end} at end')
    before, after = result.naive
    print(f'baseline, canopen Network without TappedBus: {before} frames heard in 0.5 s, then one receive '
          f'error: {after} frames heard in the next 0.5 s (its Notifier thread ended)')
    print(f'ratio: the bridge kept {result.frames_received} of {result.frames_expected} frames '
          f'({result.frames_received / max(1, result.frames_expected):.3f}); the baseline '
          f'{after / max(1, before):.3f} of its rate after the first error')


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog='python -m bench soak', description=__doc__.splitlines()[0])
    parser.add_argument('--minutes', type=float, default=10.0)
    parser.add_argument('--seed', type=int, default=1)
    args = parser.parse_args(argv)
    for name in ('drive_bridge', 'canopen', 'can'):  # the events are counted, not printed
        logging.getLogger(name).propagate = False
        logging.getLogger(name).addHandler(logging.NullHandler())
    result = run(args.minutes * 60, args.seed)
    report(result)
    counts = Counter({n: t.injected for n, t in result.tallies.items()})
    print(f'\nmost injected: {", ".join(f"{n} x{c}" for n, c in counts.most_common(3))}')
