"""The bridge's own position loop for a joint that takes only velocity set-points: a CiA 402
drive in profile velocity with `position_loop` set follows a trajectory and position commands,
holds the last desired position, and a following error beyond the limit stops the stream with
HALT and says so."""
from __future__ import annotations

import math
import time
from typing import Any

import pytest

from bustools import config_from, eventually, running, unique_channel
from drive_bridge.cia402.statemachine import State
from drive_bridge.joint import Setpoint
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint
from timingtools import assert_follows

JOINT = 'wheel_joint'
NODE = 5


def loop_bus(following_error: float = 0.05) -> dict[str, Any]:
    return {
        'bus': {'interface': 'virtual', 'channel': unique_channel('loop')},
        'master': {'sync_period': 4000},
        'nodes': {'wheel': {'node_id': NODE, 'axes': [{
            'joint': JOINT, 'mode': 'pv', 'position_mode': 'pv', 'velocity_mode': 'pv',
            'scaling': {'counts_per_revolution': 65536, 'gear_ratio': 10},
            'limits': {'max_velocity': 3.0, 'max_acceleration': 4.0},  # the drive's pv ramp: 4.8 rad/s^2
            'position_loop': {'gain': 20.0, 'following_error': following_error}}]}},
    }


def quintic(start: float, distance: float, duration: float) -> Trajectory:
    return Trajectory((JOINT,), (TrajectoryPoint(duration, (start + distance,), (0.0,), (0.0,)),))


def test_a_pv_joint_follows_a_trajectory_through_the_bridges_loop() -> None:
    with running(config_from(loop_bus())) as (master, sim):
        axis = master.axes[JOINT]
        axis.enable(timeout=2.0)
        assert axis.stream_strategy() == 'position-loop'
        executor = TrajectoryExecutor(master.axes, cycle_period=master.config.master.cycle_period)
        errors: list[float] = []

        def watch(_cycle: int) -> None:
            executor.check()
            desired = executor.desired(JOINT, executor.now() - 0.004)
            if desired is not None and executor.active():
                errors.append(abs(desired.position - axis.feedback()[1]))
        master.add_cycle_listener(watch)
        start = axis.snapshot().position
        handle = executor.submit(quintic(start, 1.0, 1.5))  # 1 rad in 1.5 s
        assert handle is not None and handle.wait(5.0)
        assert handle.state == 'succeeded', handle.reason
        time.sleep(0.4)
        final = axis.snapshot()
        assert abs(final.position - (start + 1.0)) < 5e-3  # the loop holds the last desired position
        assert abs(final.velocity) < 0.05
        assert_follows(errors, 0.05)
        # the drive only ever saw velocity set-points (pv): nothing went to 0x607A
        assert sim.drive(NODE).axis().mode == 3 and axis.snapshot().state is State.OPERATION_ENABLED


def test_position_commands_on_a_pv_joint_go_through_the_loop() -> None:
    with running(config_from(loop_bus())) as (master, _sim):
        axis = master.axes[JOINT]
        axis.enable(timeout=2.0)
        start = axis.snapshot().position
        axis.command(position=start + 0.3)
        eventually(lambda: abs(axis.snapshot().position - (start + 0.3)) < 5e-3, 3.0, 'position reached')
        for _ in range(10):  # a stream of commands keeps the dead-man fed
            axis.command(position=start + 0.3)
            time.sleep(0.01)


def test_a_following_error_beyond_the_limit_stops_the_stream_with_halt() -> None:
    with running(config_from(loop_bus(following_error=0.02))) as (master, _sim):
        axis = master.axes[JOINT]
        axis.enable(timeout=2.0)
        executor = TrajectoryExecutor(master.axes, cycle_period=master.config.master.cycle_period)
        master.add_cycle_listener(executor.check)
        start = axis.snapshot().position
        # a trajectory faster than the joint's limits is refused whole (~15 rad/s^2 and 6 rad/s) ...
        with pytest.raises(TrajectoryError, match=r'wheel_joint needs (velocity|acceleration) .* beyond its limit'):
            executor.submit(quintic(start, 2.0, 0.5))
        # ... so a desired motion the drive cannot follow comes from a source past the check: the
        # loop keeps its output within the limits, the drive falls behind, the loop's supervision holds it
        t0 = time.time()
        axis.set_setpoint_source(lambda t: Setpoint(position=start + 6.0 * min(t - t0, 0.5), velocity=6.0))
        eventually(lambda: axis.snapshot().halted, 3.0, 'the axis held by the loop')
        snapshot = axis.snapshot()
        assert snapshot.halted and snapshot.state is State.OPERATION_ENABLED
        assert 'beyond the position loop limit 0.02' in snapshot.message
        assert math.isfinite(snapshot.position)
