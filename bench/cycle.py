"""The SYNC cycle's timing under a synchronous window, a flood and a lost drive: the figures the
tests stopped asserting (they hold only behaviour bounds; on a busy 2-core machine the share of
late or skipped cycles is the machine's, not the bridge's).

All in one process, as the tests run it: the demo bus (3 nodes, 4 axes, 4 ms SYNC) on a python-can
virtual bus, the master and the simulated drives sharing the GIL. Each case is measured beside
the machine's floor (bench/floor.py: a bare sleep loop on the same grid in a process of its own,
meanwhile) and, where the case adds a load, beside the same bus without it in the same run:

- window: master.sync_window 2000 µs; share of the set-points the drives received after the
  window (discarded, as a drive does) vs the floor's share of wake-ups later than the window;
- flood: 8,000 frames/s for 1 s (unknown COB-IDs and a babbling node's EMCYs, as
  test_faults_flood sends them); share of grid points without SYNC during the flood, vs the same
  bus just before it (baseline) and the floor;
- lost: one drive's heartbeat and TPDOs stop (as test_faults_liveness); skipped share in the
  second after, vs the second before.

    .venv/bin/python -m bench cycle [--cases window flood lost] [--seconds 3] [--repeat 3]
"""
from __future__ import annotations

import argparse
import logging
import statistics
import tempfile
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

import can
import yaml

from bench.floor import Floor
from drive_bridge.config import parse_bus_config
from drive_bridge.joint import Setpoint
from drive_bridge.master.master import Master
from drive_bridge.sim import SimulatedBus

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / 'config' / 'demo.yaml'
WINDOW_US = 2000
FLOOD_RATE = 8000  # frames/s
FLOOD_FRAMES = (can.Message(arbitration_id=0x7F0, data=b'\x01' * 8, is_extended_id=False),
                can.Message(arbitration_id=0x082, data=b'\x00\x10\x01\x00\x00\x00\x00\x00', is_extended_id=False))
CASES = ('window', 'flood', 'lost')


def demo_bus(**master: Any) -> Any:
    data = yaml.safe_load(DEMO.read_text())
    data['bus']['channel'] = f'bench-cycle-{uuid.uuid4().hex[:8]}'
    data['master'].update(master)
    return parse_bus_config(data, 'bench cycle', DEMO.parent)


def stream(master: Master) -> None:
    """Every axis enabled in CSP, a slow ramp streamed on each, one set-point per cycle."""
    for axis in master.axes.values():
        axis.enable(timeout=3.0)
        axis.set_mode('csp')
        p0, t0 = axis.commanded_position(), time.time()
        axis.set_setpoint_source(lambda t, p0=p0, t0=t0: Setpoint(position=p0 + 0.01 * (t - t0)))


def skip_share(master: Master, action: Callable[[], None]) -> float:
    """Share of the grid points without SYNC while ``action`` runs."""
    assert master.sync is not None
    cycles, skipped = master.sync.cycles, master.sync.skipped
    action()
    done, missed = master.sync.cycles - cycles, master.sync.skipped - skipped
    return missed / max(1, done + missed)


def flood(channel: str, frames: tuple[can.Message, ...] = FLOOD_FRAMES, seconds: float = 1.0,
          rate: int = FLOOD_RATE) -> float:
    """``frames`` round robin at ``rate`` for ``seconds``, paced in 5 ms slices (test_faults_flood
    sends the same); the seconds it took."""
    rogue = can.Bus(interface='virtual', channel=channel)
    start, per_slice = time.monotonic(), int(rate * 0.005)
    try:
        for i in range(int(seconds / 0.005)):
            for k in range(per_slice):
                rogue.send(frames[(i * per_slice + k) % len(frames)])
            delay = start + (i + 1) * 0.005 - time.monotonic()
            if delay > 0:
                time.sleep(delay)
    finally:
        rogue.shutdown()
    return time.monotonic() - start


def run_case(case: str, seconds: float, work: Path) -> dict[str, float]:
    config = demo_bus(sync_window=WINDOW_US) if case == 'window' else demo_bus()
    period = config.master.sync_period
    sim = SimulatedBus(config).start()
    master = Master(config)
    try:
        master.start()
        master.wait_until_operational(10.0)
        stream(master)
        time.sleep(0.5)
        drives = [sim.drive(n.node_id) for n in config.nodes]
        if case == 'window':
            before = [(d.pdo.rpdo_received, d.pdo.rpdo_late) for d in drives]
            with Floor(period, seconds, work, (WINDOW_US * 1e-6,)) as floor:
                time.sleep(seconds)
            received = sum(d.pdo.rpdo_received - b[0] for d, b in zip(drives, before))
            late = sum(d.pdo.rpdo_late - b[1] for d, b in zip(drives, before))
            return {'figure': late / max(1, received), 'baseline': float('nan'),
                    'floor': floor.result['late_share'][str(WINDOW_US * 1e-6)]}
        if case == 'flood':
            with Floor(period, 2 * seconds, work) as floor:
                baseline = skip_share(master, lambda: time.sleep(seconds))
                figure = skip_share(master, lambda: flood(config.bus.channel, seconds=seconds))
            return {'figure': figure, 'baseline': baseline, 'floor': floor.result['skip_share']}
        with Floor(period, 2 * seconds, work) as floor:  # lost
            baseline = skip_share(master, lambda: time.sleep(seconds))
            drives[-1].stop_heartbeat()
            drives[-1].stop_tpdos()
            figure = skip_share(master, lambda: time.sleep(seconds))
        return {'figure': figure, 'baseline': baseline, 'floor': floor.result['skip_share']}
    finally:
        master.stop()
        sim.stop()


FIGURE = {'window': 'set-points after the window', 'flood': 'skipped during the flood',
          'lost': 'skipped after the loss'}


def _pct(value: float) -> str:
    return '-' if value != value else f'{100 * value:.1f} %'


def _ratio(figure: float, floor: float) -> str:
    if figure != figure or floor != floor:
        return '-'
    return f'{figure / floor:.1f}x' if floor > 0 else ('1.0x' if figure == 0 else 'inf (floor 0)')


def main(argv: list[str] | None = None) -> None:
    logging.disable(logging.CRITICAL)  # the master's own reports of the faults the cases inject
    parser = argparse.ArgumentParser(prog='python -m bench cycle', description=__doc__.split('\n\n')[0])
    parser.add_argument('--cases', nargs='+', choices=CASES, default=list(CASES))
    parser.add_argument('--seconds', type=float, default=3.0, help='measurement window per case (default 3)')
    parser.add_argument('--repeat', type=int, default=3, help='runs per case; the median is shown (default 3)')
    options = parser.parse_args(argv)
    print('share of set-points / grid points; baseline = the same bus without the load, just before; '
          "floor = a bare sleep loop on the grid in another process meanwhile (the machine's); "
          f'median of {options.repeat}')
    print('| case | figure | value | baseline | floor | value / floor |\n|---|---|---|---|---|---|')
    with tempfile.TemporaryDirectory(prefix='bench-cycle-') as tmp:
        for case in options.cases:
            runs = [run_case(case, options.seconds, Path(tmp)) for _ in range(options.repeat)]
            median = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
            print(f"| {case} | {FIGURE[case]} | {_pct(median['figure'])} | {_pct(median['baseline'])} | "
                  f"{_pct(median['floor'])} | {_ratio(median['figure'], median['floor'])} |", flush=True)


if __name__ == '__main__':
    main()
