"""Per-SYNC cost of one simulated 1-axis drive: ``python -m drive_bridge.sim.bench``.

The drive runs CSP in Operation Enabled with the family default PDO map (two RPDOs
latched, two TPDOs sent per SYNC). Measured is the time inside the drive's SYNC
handler (RPDO apply, model step, statusword, packing and sending two TPDOs), first
with a paced SYNC from a test-side master (includes waiting for the GIL and the
slave lock while the master's threads run), then in a tight loop (the handler alone;
about half of it is python-can's virtual-bus send: a Message and a deepcopy per
receiving bus).
"""
from __future__ import annotations

import argparse
import statistics
import struct
import time

from drive_bridge.sim.drive402 import SimDrive402
from drive_bridge.sim.testing import SimBench, SyncLoop, wait_until

NODE = 1


def measure(cycles: int = 2000, period: float = 0.002) -> dict[str, float]:
    """Mean and max SYNC handler time (s) paced at ``period``, and the tight-loop mean."""
    with SimBench() as bench:
        sim, node = bench.add_drive(NODE)
        assert isinstance(sim, SimDrive402)
        node.sdo[0x6060].raw = 8
        for cw in (0x06, 0x07, 0x0F):
            node.sdo[0x6040].raw = cw
        bench.nmt(0x01, NODE)
        wait_until(lambda: sim.nmt_state == 'OPERATIONAL', 1.0)

        def before(i: int) -> None:
            bench.send(0x200 + NODE, struct.pack('<Hbh', 0x0F, 8, 0))
            bench.send(0x300 + NODE, struct.pack('<ii', 10 * i, 0))

        sim.sync_cost.reset()
        SyncLoop(bench.master, period).run(cycles, before)
        time.sleep(0.05)
        paced = sim.sync_cost.count, sim.sync_cost.mean, sim.sync_cost.median, sim.sync_cost.max
        # tight loop: the handler alone, frames latched as the bus would deliver them
        samples = []
        rpdo1 = sim.pdo.rpdos[1]
        rpdo2 = sim.pdo.rpdos[2]
        for i in range(cycles):
            rpdo1.latched = struct.pack('<Hbh', 0x0F, 8, 0)
            rpdo2.latched = struct.pack('<ii', 10 * (cycles + i), 0)
            start = time.perf_counter()
            sim.sync_clock.on_sync(0x80, bytearray(), time.time())
            samples.append(time.perf_counter() - start)
        return {'paced_count': paced[0], 'paced_mean': paced[1], 'paced_median': paced[2], 'paced_max': paced[3],
                'tight_mean': statistics.fmean(samples), 'tight_median': statistics.median(samples),
                'tight_p99': sorted(samples)[int(0.99 * len(samples))]}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--cycles', type=int, default=2000)
    parser.add_argument('--period', type=float, default=0.002, help='SYNC period, s')
    args = parser.parse_args(argv)
    result = measure(args.cycles, args.period)
    print(f'paced ({result["paced_count"]:.0f} SYNCs at {args.period * 1000:g} ms): '
          f'mean {result["paced_mean"] * 1e6:.0f} us, median {result["paced_median"] * 1e6:.0f} us, '
          f'max {result["paced_max"] * 1e6:.0f} us')
    print(f'tight loop: mean {result["tight_mean"] * 1e6:.0f} us, median {result["tight_median"] * 1e6:.0f} us, '
          f'p99 {result["tight_p99"] * 1e6:.0f} us')


if __name__ == '__main__':
    main()
