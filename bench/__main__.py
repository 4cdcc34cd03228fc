"""``python -m bench NAME [options]``, NAME one of tracking, memory, recording, diagnose, diagnose_lens,
transport, ros_cycle, soak, motion_check, cycle, reactions, boundary, boundary_mechanism: run a benchmark and
print its table."""
from __future__ import annotations

import os
import sys

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

BENCHMARKS = {'tracking': 'bench.tracking', 'memory': 'bench.memory', 'recording': 'bench.recording',
              'diagnose': 'bench.diagnose', 'transport': 'bench.transport', 'ros_cycle': 'bench.ros_cycle',
              'soak': 'bench.soak', 'motion_check': 'bench.motion_check',
              'diagnose_lens': 'bench.diagnose_lens', 'cycle': 'bench.cycle', 'reactions': 'bench.reactions',
              'boundary_mechanism': 'bench.boundary_mechanism', 'boundary': 'bench.boundary'}


def main() -> None:
    args = sys.argv[1:]
    name = args.pop(0) if args and args[0] in BENCHMARKS else 'tracking'
    module = __import__(BENCHMARKS[name], fromlist=['main'])
    module.main(args)


if __name__ == '__main__':
    main()
