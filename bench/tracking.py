"""Tracking benchmark: how accurately simulated drives follow trajectories streamed by the
bridge, per streaming strategy and SYNC period.

For each strategy (cyclic synchronous position, linear interpolated position, PVT, and the
bridge's own position loop over velocity set-points on a SINAMICS S120 in pv) and SYNC
period, 4 axes run two smooth trajectories (a quintic point-to-point move and a sum of
sines). The drive's interpolated position (demand, 0x6062; for the velocity-only S120 its
actual position) is recorded inside each simulated drive at every SYNC and compared with
the ideal trajectory at the SYNC's time on the bridge's stream clock; "stream delay" is how
far that clock fell behind wall time because the cycle thread stalled for more than two
periods (it then delays the motion rather than jumping the set-point).

    .venv/bin/python -m bench tracking [--periods 1 2 4 10] [--strategies csp ip pvt s120-pv]

The S120 runs with its CAN sampling time p8848 at half the SYNC period (the drive needs
RPDOs no faster than 2 x p8848; p8848 >= 1 ms, so only periods >= 2 ms), on the real
Siemens EDS of ../shared/realdata (skipped when it is not there).
"""
from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from drive_bridge.config import parse_bus_config
from drive_bridge.families import family_names
from drive_bridge.master.master import Master
from drive_bridge.sim import SimulatedBus
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint

COUNTS_PER_REV = {'generic_402': 2 ** 16, 'akd': 2 ** 20}  # AKD: 2^20 increments per revolution
S120_EDS = (Path(__file__).resolve().parents[2] / 'shared' / 'realdata' / 'eds'
            / 'SINAMICS_S120_V48__SINAMICS_S120.eds')
AXES = 4
START_DELAY = 0.3  # s between submitting and the trajectory start
Ideal = Callable[[float], tuple[float, float, float]]  # t from start -> (position, velocity, acceleration)


def quintic(amplitude: float, duration: float) -> Ideal:
    def f(t: float) -> tuple[float, float, float]:
        u = min(max(t / duration, 0.0), 1.0)
        s = 10 * u ** 3 - 15 * u ** 4 + 6 * u ** 5
        ds = (30 * u ** 2 - 60 * u ** 3 + 30 * u ** 4) / duration
        dds = (60 * u - 180 * u ** 2 + 120 * u ** 3) / duration ** 2
        return amplitude * s, amplitude * ds, amplitude * dds
    return f


def sines(a1: float, f1: float, a2: float, f2: float) -> Ideal:
    w1, w2 = 2 * math.pi * f1, 2 * math.pi * f2

    def f(t: float) -> tuple[float, float, float]:
        return (a1 * math.sin(w1 * t) + a2 * math.sin(w2 * t),
                a1 * w1 * math.cos(w1 * t) + a2 * w2 * math.cos(w2 * t),
                -a1 * w1 ** 2 * math.sin(w1 * t) - a2 * w2 ** 2 * math.sin(w2 * t))
    return f


# name -> (duration, per-axis ideals, waypoint spacing)
TRAJECTORIES: dict[str, tuple[float, list[Ideal], float]] = {
    'quintic p2p': (1.5, [quintic(a, 1.5) for a in (1.0, -0.6, 0.4, 1.5)], 1.5),
    'sum of sines': (2.0, [sines(0.1 * k, 1.0, 0.05, 3.0) for k in (1, 2, 3, 4)], 0.02),
}
STRATEGIES = {'csp': ('generic_402', 'csp', 'linear'), 'ip': ('generic_402', 'ip', 'linear'),
              'pvt': ('akd', 'ip', 'pvt'), 's120-pv': ('sinamics_s120', 'pv', 'linear')}
VELOCITY_ONLY = {'s120-pv'}  # measured at the drive's actual position (it has no demand position)


def unavailable(strategy: str, period_ms: float) -> str:
    """Why a case cannot run here ('' when it can)."""
    family = STRATEGIES[strategy][0]
    if family not in family_names():
        return f'drive family {family!r} is not available'
    if family == 'sinamics_s120' and not S120_EDS.is_file():
        return f'the Siemens EDS {S120_EDS} is not there'
    if family == 'sinamics_s120' and period_ms < 2:
        return 'the S120 needs SYNC >= 2 x p8848 and p8848 >= 1 ms'
    return ''


def bus_data(strategy: str, period_ms: float, channel: str) -> dict:
    family, mode, interpolation = STRATEGIES[strategy]
    if family == 'sinamics_s120':
        return s120_bus_data(period_ms, channel)
    axis = {'mode': mode, 'interpolation': interpolation,
            'scaling': {'counts_per_revolution': COUNTS_PER_REV[family], 'rated_torque': 1.0}}
    return {  # the 1 ms rows exceed a 1 Mbit/s bus: measured anyway (the bus budget check would refuse)
        'bus': {'interface': 'virtual', 'channel': channel, 'allow_overload': True},
        'master': {'node_id': 127, 'sync_period': round(period_ms * 1000), 'heartbeat_producer': 100},
        'nodes': {f'drive{i}': {'node_id': i, 'family': family, 'axes': [{'joint': f'j{i}', **axis}]}
                  for i in range(1, AXES + 1)},
        'simulation': {'enabled': True},
    }


def s120_bus_data(period_ms: float, channel: str) -> dict:
    """Four one-DO S120 nodes in pv, guarded, the bridge closing the position loop; the
    simulated drives' p8848 is half the SYNC period and their ramps are 1 s to n_max."""
    axis = {'mode': 'pv', 'limits': {'max_velocity': 10.0}}
    return {
        'bus': {'interface': 'virtual', 'channel': channel, 'allow_overload': True},
        'master': {'node_id': 127, 'sync_period': round(period_ms * 1000)},
        'nodes': {f'drive{i}': {'node_id': i, 'family': 'sinamics_s120', 'dcf': str(S120_EDS), 'guard_time_ms': 100,
                                'axes': [{'joint': f'j{i}', **axis}]} for i in range(1, AXES + 1)},
        # commissioned drives: OFF3 when the bridge is lost (p8641 = 3), ramps 1 s to n_max
        'simulation': {'enabled': True, 'nodes': {f'drive{i}': {'p8641': 3, 'p8848': period_ms / 2,
                                                                'ramp_up_time': 1.0, 'ramp_down_time': 1.0}
                                                  for i in range(1, AXES + 1)}},
    }


def trajectory_for(name: str, start: float) -> Trajectory:
    duration, ideals, spacing = TRAJECTORIES[name]
    steps = max(1, round(duration / spacing))
    points = []
    for k in range(0 if spacing < duration else 1, steps + 1):
        t = duration * k / steps
        samples = [f(t) for f in ideals]
        points.append(TrajectoryPoint(t, tuple(s[0] for s in samples), tuple(s[1] for s in samples),
                                      tuple(s[2] for s in samples)))
    return Trajectory(tuple(f'j{i}' for i in range(1, AXES + 1)), tuple(points), start)


@dataclass
class Row:
    strategy: str
    period_ms: float
    trajectory: str
    max_error: float
    rms_error: float
    lead_median_us: float
    lead_max_us: float
    underflows: int
    overflows: int
    frames_per_s: float
    skipped: int
    delay_ms: float


def record_demand(sim: SimulatedBus, executor: TrajectoryExecutor,
                  actual: bool = False) -> dict[int, list[tuple[float, int, float]]]:
    """(SYNC timestamp, demand (or actual) position, stream delay) of each simulated drive's
    axis 0 after every SYNC step."""
    records: dict[int, list[tuple[float, int, float]]] = {}
    for node_id, drive in sim.drives.items():
        log: list[tuple[float, int]] = []
        records[node_id] = log
        original = drive.model_step

        def step(dt: float, sync: bool, drive=drive, log=log, original=original) -> None:
            original(dt, sync)
            if sync:
                axis = drive.axes[0]
                log.append((drive._prev_sync_stamp, axis.position if actual else axis.demand_position, executor.lag))
        drive.model_step = step
    return records


def run_case(strategy: str, period_ms: float, name: str, channel: str) -> Row:
    config = parse_bus_config(bus_data(strategy, period_ms, channel), 'bench', Path.cwd())
    period = period_ms / 1000.0
    sim = SimulatedBus(config).start()
    master = Master(config)
    emcy_codes: list[int] = []
    master.add_emcy_listener(lambda e: emcy_codes.append(e.code))
    try:
        master.start()
        master.wait_until_operational(10.0)
        for axis in master.axes.values():
            axis.enable(timeout=3.0)
            axis.set_mode(axis.config.mode, timeout=3.0)
        executor = TrajectoryExecutor(master.axes, cycle_period=period,
                                      pvt_segment=max(0.01, round(2 * period, 3)),
                                      pvt_lookahead=max(0.05, 6 * period))
        master.add_cycle_listener(executor.check)
        records = record_demand(sim, executor, actual=strategy in VELOCITY_ONLY)
        traffic_before, since = master.traffic.traffic(), time.monotonic()
        skipped_before = master.sync.skipped if master.sync else 0
        start = time.time() + START_DELAY
        handle = executor.submit(trajectory_for(name, start), 'bench')
        duration = TRAJECTORIES[name][0]
        time.sleep(START_DELAY + duration + 0.4)
        elapsed = time.monotonic() - since
        traffic = master.traffic.traffic()
        stats = master.sync.stats() if master.sync else None
        skipped = (master.sync.skipped - skipped_before) if master.sync else 0
        errors = []
        ideals = TRAJECTORIES[name][1]
        delay = 0.0
        for node_id, log in records.items():
            factor = master.axes[f'j{node_id}'].config.scaling.position_factor
            for stamp, demand, lag in log:  # against the ideal on the stream clock (see delay)
                if start <= stamp - lag <= start + duration:
                    errors.append(demand * factor - ideals[node_id - 1](stamp - lag - start)[0])
                    delay = max(delay, lag)
        underflows = emcy_codes.count(0x8585)
        overflows = emcy_codes.count(0x8584) + sum(getattr(d.axes[0], 'ip', None) and d.axes[0].ip.overflows or 0
                                                   for d in sim.drives.values())
        if handle is not None and handle.state == 'aborted':
            print(f'  note: {strategy} {period_ms} ms {name}: aborted: {handle.reason}')
        return Row(strategy, period_ms, name,
                   max((abs(e) for e in errors), default=math.nan),
                   math.sqrt(statistics.fmean(e * e for e in errors)) if errors else math.nan,
                   (stats.lead_median if stats else 0) * 1e6, (stats.lead_max if stats else 0) * 1e6,
                   underflows, overflows,
                   (traffic.rx_frames + traffic.tx_frames
                    - traffic_before.rx_frames - traffic_before.tx_frames) / elapsed,
                   skipped, delay * 1000)
    finally:
        master.stop()
        sim.stop()


def median_row(runs: list[Row]) -> Row:
    """Each numeric figure's median over repeated runs of one case."""
    first = runs[0]
    figures = {f: statistics.median(getattr(r, f) for r in runs) for f in Row.__dataclass_fields__
               if f not in ('strategy', 'period_ms', 'trajectory')}
    return Row(first.strategy, first.period_ms, first.trajectory, **figures)


def table(rows: list[Row]) -> str:
    head = ('| strategy | SYNC | trajectory | max error (rad) | RMS error (rad) | lead median / worst (µs) '
            '| underflows | overflows | CAN frames/s | skipped SYNCs | stream delay (ms) |\n'
            '|---|---|---|---|---|---|---|---|---|---|---|')
    lines = [f'| {r.strategy} | {r.period_ms:g} ms | {r.trajectory} | {r.max_error:.2e} | {r.rms_error:.2e} | '
             f'{r.lead_median_us:.0f} / {r.lead_max_us:.0f} | {r.underflows} | {r.overflows} | '
             f'{r.frames_per_s:.0f} | {r.skipped} | {r.delay_ms:.0f} |' for r in rows]
    return '\n'.join([head, *lines])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog='bench tracking', description=__doc__.split('\n\n')[0])
    parser.add_argument('--periods', nargs='+', type=float, default=[1, 2, 4, 10], help='SYNC periods in ms')
    parser.add_argument('--strategies', nargs='+', default=list(STRATEGIES), choices=list(STRATEGIES))
    parser.add_argument('--trajectories', nargs='+', default=list(TRAJECTORIES), choices=list(TRAJECTORIES))
    parser.add_argument('--repeat', type=int, default=1,
                        help='runs per case; the table gives the median of each figure (the VM is noisy)')
    options = parser.parse_args(argv)
    rows = []
    for strategy in options.strategies:
        for period in options.periods:
            why = unavailable(strategy, period)
            if why:
                print(f'skipping {strategy} at {period:g} ms: {why}')
                continue
            for name in options.trajectories:
                runs = [run_case(strategy, period, name, f'bench-{strategy}-{period}-{name}-{time.monotonic_ns()}')
                        for _ in range(max(1, options.repeat))]
                rows.append(median_row(runs))
                print(table(rows[-1:]).splitlines()[-1], flush=True)
    print()
    print(table(rows))
