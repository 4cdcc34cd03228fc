"""Trajectory streaming in the core (no ROS) against simulated drives: a stalled cycle
delays the stream instead of making the set-point jump."""
from __future__ import annotations

import time

from bustools import config_from, demo_data, running
from drive_bridge.cia402.statemachine import State
from drive_bridge.streaming.executor import TrajectoryExecutor
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint
from timingtools import BUSY_SLACK


def test_a_stalled_sync_thread_delays_the_trajectory_instead_of_faulting_the_drive() -> None:
    with running(config_from(demo_data())) as (master, sim):
        axis = master.axes['elbow_joint']
        axis.enable(timeout=2.0)
        executor = TrajectoryExecutor(master.axes, cycle_period=master.config.master.cycle_period)
        master.add_cycle_listener(executor.check)
        stalled = []

        def stall(cycle: int) -> None:  # the cycle thread stops for 200 ms once, mid-motion
            if not stalled and executor.active() and time.time() > executor.active()[0].start + 0.5:
                stalled.append(cycle)
                time.sleep(0.2)
        master.sync.add_before_sync(stall)
        here = axis.snapshot().position
        # 0.55 rad/s at the stall (the drive's top speed is 0.64 rad/s at this gear ratio):
        # jumping 200 ms ahead would be a 0.11 rad step, beyond the drive's following error
        # window (20000 counts = 0.064 rad)
        handle = executor.submit(Trajectory(('elbow_joint',), (
            TrajectoryPoint(0.5, (here - 0.1375,), (-0.55,)), TrajectoryPoint(1.0, (here - 0.4125,), (-0.55,)),
            TrajectoryPoint(1.5, (here - 0.55,), (0.0,)))))
        assert handle.wait(5.0)
        # the stream clock fell behind by the stall (200 ms, more on a busy machine)
        assert stalled and executor.stalls >= 1 and 0.15 < executor.lag < 0.2 + BUSY_SLACK, executor.lag
        assert handle.state == 'succeeded', handle.reason
        assert axis.snapshot().state is State.OPERATION_ENABLED  # no following error fault
        time.sleep(0.3)
        assert abs(axis.snapshot().position - (here - 0.55)) < 1e-3
        assert sim.drive(3).axis(1).fault_code == 0


def test_a_velocity_only_trajectory_is_integrated_and_streamed_in_csv() -> None:
    """joint_trajectory_controller's allow_integration_in_goal_trajectories: points with
    velocities and no positions; the axis ends where the integrated velocities say."""
    from drive_bridge.streaming.errors import TrajectoryError
    with running(config_from(demo_data())) as (master, sim):
        axis = master.axes['elbow_joint']
        axis.enable(timeout=2.0)
        executor = TrajectoryExecutor(master.axes, cycle_period=master.config.master.cycle_period)
        master.add_cycle_listener(executor.check)
        velocity_only = Trajectory(('elbow_joint',), (
            TrajectoryPoint(0.4, (), (0.3,)), TrajectoryPoint(0.8, (), (0.3,)), TrajectoryPoint(1.2, (), (0.0,))))
        try:  # csp takes positions: a trajectory without them is refused, naming the mode
            executor.submit(velocity_only)
            raise AssertionError('a velocity-only trajectory was accepted in csp')
        except TrajectoryError as exc:
            assert 'without positions needs a velocity streaming mode' in str(exc)
        axis.set_mode('csv')
        here = axis.snapshot().position
        handle = executor.submit(velocity_only)
        assert handle is not None and handle.wait(5.0)
        assert handle.state == 'succeeded', handle.reason
        # 0.3 rad/s ramp in over 0.4 s, 0.4 s at 0.3, ramp out over 0.4 s: 0.24 rad
        time.sleep(0.3)
        assert abs(axis.snapshot().position - (here + 0.24)) < 0.02
        assert axis.snapshot().state is State.OPERATION_ENABLED


def test_a_held_joint_refuses_a_trajectory_until_resumed() -> None:
    """A joint held with HALT (here ~/halt; also a PVT buffer underflow) would abort a trajectory
    at its first cycle: it is refused at once, saying why, and taken again once resumed."""
    from drive_bridge.streaming.errors import TrajectoryError
    with running(config_from(demo_data())) as (master, sim):
        axis = master.axes['elbow_joint']
        axis.enable(timeout=2.0)
        executor = TrajectoryExecutor(master.axes, cycle_period=master.config.master.cycle_period)
        master.add_cycle_listener(executor.check)
        here = axis.snapshot().position
        move = Trajectory(('elbow_joint',), (TrajectoryPoint(0.5, (here - 0.1,), (0.0,)),))
        axis.halt(True)
        try:
            executor.submit(move)
            raise AssertionError('a trajectory for a held joint was accepted')
        except TrajectoryError as exc:
            assert 'joint elbow_joint is held (HALT)' in str(exc) and 'resume it first' in str(exc), str(exc)
        assert not executor.active()
        axis.halt(False)
        handle = executor.submit(move)
        assert handle is not None and handle.wait(2.0 + BUSY_SLACK)
        assert handle.state == 'succeeded', handle.reason
        time.sleep(0.2)
        assert abs(axis.snapshot().position - (here - 0.1)) < 1e-3
