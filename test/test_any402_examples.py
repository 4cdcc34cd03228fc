"""The shipped example configs for common CiA 402 drive lines (config/*_example.yaml with a
vendor EDS): each loads, boots against its simulated drive, enables in the mode the drive's
0x6502 gives, and follows a short trajectory."""
from __future__ import annotations

import time
from pathlib import Path

import pytest

from drive_bridge.cia402.statemachine import State
from drive_bridge.config import load_bus_config
from drive_bridge.master.events import EventKind
from drive_bridge.master.master import Master
from drive_bridge.sim import SimulatedBus
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint

CONFIG_DIR = Path(__file__).resolve().parents[1] / 'config'
EXAMPLES = {'maxon_epos4': 'csp', 'elmo': 'csp', 'nanotec': 'csp', 'faulhaber': 'pv', 'technosoft': 'ip'}


@pytest.mark.parametrize('line', sorted(EXAMPLES))
def test_example_config_boots_and_moves(line: str) -> None:
    config = load_bus_config(CONFIG_DIR / f'{line}_example.yaml')
    (node,) = config.nodes
    assert config.simulation.enabled and node.family == 'generic_402' and node.pdo_summary.startswith('PDO map')
    assert node.eds_path is not None and 'shared/realdata/eds' in node.eds_path.as_posix()
    sim = SimulatedBus(config).start()
    master = Master(config)
    try:
        master.start()
        master.wait_until_operational(5.0)
        (axis,) = master.axes.values()
        axis.enable(2.0)
        deadline = time.monotonic() + 2.0
        while axis.snapshot().mode_name != EXAMPLES[line] and time.monotonic() < deadline:
            time.sleep(0.01)
        assert axis.snapshot().mode_name == EXAMPLES[line]
        # one start-up line for the node's map, one for the axis' mode, each once
        lines = [e.message for e in master.events if e.kind is EventKind.CONFIGURED]
        assert lines == [f'node {node.node_id} ({node.name}): {node.pdo_summary}',
                         f"axis '{axis.joint}' (node {node.node_id} {node.name}, slot 0): mode {EXAMPLES[line]}"
                         + lines[1].split(f'mode {EXAMPLES[line]}', 1)[1]]
        executor = TrajectoryExecutor(master.axes, cycle_period=config.master.cycle_period)
        master.add_cycle_listener(executor.check)
        start = axis.snapshot().position
        handle = executor.submit(Trajectory((axis.joint,), (TrajectoryPoint(0.3, (start + 0.1,)),)))
        assert handle is not None and handle.wait(3.0)
        deadline = time.monotonic() + 1.0
        while abs(axis.snapshot().position - start - 0.1) > 3e-3 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert axis.snapshot().position == pytest.approx(start + 0.1, abs=3e-3)
        assert axis.state is State.OPERATION_ENABLED
    finally:
        master.stop()
        sim.stop()
