"""Executing trajectories on the axes of one bus, sampled each cycle (CSP/CSV).

Per joint, the spline in force at a time is the newest one whose start is not later:
a replacement takes over at its own start time, and its lead-in starts from the
replaced trajectory's desired state at that time (a smooth splice). Joints of the bus
that a trajectory leaves out hold their desired position from its start
(joint_trajectory_controller's partial-goal rule).
"""
from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.joint import DriveState, JointDriver, JointError, Setpoint
from drive_bridge.joint.strategy import NOT_STREAMED, StreamStrategy
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.planning import plan
from drive_bridge.streaming.pvt import PvtFeeder
from drive_bridge.streaming.trajectory import (
    JointSample,
    JointSpline,
    Trajectory,
    validate,
)

STALL_PERIODS = 2  # a cycle later than this many periods delays the stream (see _tick)


@dataclass
class TrajectoryHandle:
    """A submitted trajectory: its time span and how it ended."""

    id: int
    joints: tuple[str, ...]
    start: float
    end: float
    state: str = 'pending'  # pending, active, succeeded, superseded, aborted, cancelled
    reason: str = ''
    notes: tuple[str, ...] = ()  # what planning changed (past points dropped, segments stretched)
    warnings: tuple[str, ...] = ()  # what it could not check (a joint without a velocity limit)
    _done: threading.Event = field(default_factory=threading.Event, repr=False)

    def finish(self, state: str, reason: str = '') -> None:
        if not self._done.is_set():
            self.state, self.reason = state, reason
            self._done.set()

    @property
    def finished(self) -> bool:
        return self._done.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        return self._done.wait(timeout)


class TrajectoryExecutor:
    """Accepts trajectories for the bus's joints and feeds each axis one setpoint per cycle."""

    def __init__(self, axes: Mapping[str, JointDriver], clock: Callable[[], float] = time.time,
                 cycle_period: float = 0.004, pvt_segment: float = 0.01, pvt_lookahead: float = 0.05,
                 scale_to_limits: bool = False) -> None:
        self.axes = dict(axes)
        self.scale_to_limits = scale_to_limits  # stretch segments beyond the limits instead of refusing
        self.clock = clock
        self.cycle_period = cycle_period
        self.pvt_segment = pvt_segment
        self.pvt_lookahead = pvt_lookahead
        self._feeders: dict[str, PvtFeeder] = {}
        self.lag = 0.0  # s the stream clock is behind the wall clock (stalled cycles)
        self.stalls = 0
        self._last_tick = 0.0
        self._lock = threading.Lock()
        self._splines: dict[str, list[JointSpline]] = {j: [] for j in self.axes}
        self._owner: dict[str, TrajectoryHandle | None] = {j: None for j in self.axes}
        self._handles: list[TrajectoryHandle] = []
        self._ids = itertools.count(1)

    # -- submitting -----------------------------------------------------------------------
    def _check_axes(self, joints: Iterable[str], source: str, fields: tuple[bool, bool] = (True, False)) -> None:
        """Each joint is available, enabled, in a streaming mode, and (its driver says) can
        follow a trajectory with these fields (has positions, has velocities)."""
        for joint in joints:
            axis = self.axes[joint]
            snapshot = axis.snapshot()
            if not snapshot.available:
                raise TrajectoryError(f'{source}: joint {joint} is not available (node {snapshot.node_id} '
                                      f'NMT {snapshot.nmt_state})')
            if snapshot.drive_state is DriveState.FAULT:
                raise TrajectoryError(f'{source}: joint {joint} is {axis.fault_description()}')
            if snapshot.drive_state is not DriveState.ENABLED:
                raise TrajectoryError(f'{source}: joint {joint} is {snapshot.state_label}, not operation '
                                      'enabled; enable it first (~/enable)')
            try:  # first: the driver's own reason (e.g. a mode the drive lacks)
                axis.check_trajectory(*fields)
            except JointError as exc:
                raise TrajectoryError(f'{source}: {exc}') from None
            if axis.stream_strategy() is None:
                raise TrajectoryError(f'{source}: joint {joint} is in mode {snapshot.mode_name}, which takes '
                                      'no trajectory; set a streaming mode first (csp, csv or ip; set_mode)')

    def _check_not_held(self, joints: Iterable[str], source: str) -> None:
        """A joint held with HALT (~/halt, a buffer underflow or overflow, the position loop's
        following error) takes no trajectory until resumed: accepted, it would be aborted at the
        next cycle (check), and on the topic nobody would hear why the joint did not move."""
        for joint in joints:
            snapshot = self.axes[joint].snapshot()
            if snapshot.halted:
                why = f': {snapshot.message}' if snapshot.message else ''
                raise TrajectoryError(f'{source}: joint {joint} is held (HALT){why}; resume it first (~/resume)')

    def desired(self, joint: str, t: float) -> JointSample | None:
        """The desired state of a joint at time t, None when no trajectory ever ran."""
        splines = self._splines[joint]
        for spline in reversed(splines):
            if spline.start_time <= t:
                return spline.sample(t)
        return splines[0].sample(t) if splines else None

    def _start_state(self, joint: str, t: float) -> JointSample:
        """Where a new trajectory of a joint starts: the running one's desired state at
        its start (smooth splice), else the position the drive is commanded to now."""
        desired = self.desired(joint, t)
        if desired is not None and self._owner[joint] is not None:
            return desired
        return JointSample(self.axes[joint].commanded_position(), 0.0, 0.0)

    def submit(self, trajectory: Trajectory, source: str = 'trajectory') -> TrajectoryHandle | None:
        """Validate and schedule a trajectory; an empty one stops its joints (all if none
        are named) and returns None. TrajectoryError says why a trajectory was refused."""
        now = self.now()
        if not trajectory.points:
            self.stop(trajectory.joints or tuple(self.axes), 'stopped by an empty trajectory', smooth=True)
            return None
        limits = {j: a.config.limits for j, a in self.axes.items()}
        arrays = validate(trajectory, limits, source, waypoint_velocities=not self.scale_to_limits)
        start = trajectory.start - self.lag if trajectory.start else now
        if start + trajectory.points[-1].time < now:
            raise TrajectoryError(f'{source}: ends {now - start - trajectory.points[-1].time:.3f} s in the past '
                                  '(header.stamp too old)')
        held = tuple(j for j in self.axes if j not in trajectory.joints and self._owner[j] is not None)
        first = trajectory.points[0]
        self._check_axes(trajectory.joints, source, (bool(first.positions), bool(first.velocities)))
        self._check_not_held(trajectory.joints, source)
        self._check_axes(held, source)
        # a PVT stream already committed points to the drive: splice after them
        horizons = [f.horizon for j, f in self._feeders.items() if j in trajectory.joints or j in held]
        committed = max((h for h in horizons if h is not None), default=0.0)
        with self._lock:
            def states(at: float) -> dict[str, JointSample]:
                return {j: self._start_state(j, at) for j in (*trajectory.joints, *held)}
            # set-points are sampled one cycle ahead, for a SYNC up to a cycle ahead: a motion starting
            # before the cycle that first samples it would catch up the time since in one cycle (a step).
            # Planning takes time too (more on a busy machine): planned again, later, if it took so long
            # that the start is no longer ahead of the next cycle
            margin = 2 * self.cycle_period
            for _attempt in range(3):
                began = self.now()
                planned = plan(trajectory, start, now, states, limits, self.scale_to_limits, source,
                               max(committed, began + margin), arrays)
                took = self.now() - began
                if self.now() + self.cycle_period <= planned.start:
                    break
                margin += took + self.cycle_period
            start, splines = planned.start, planned.splines
            end = start + planned.duration
            for joint in held:  # partial goal: the other joints hold their desired position
                position = self._start_state(joint, start).position
                splines[joint] = JointSpline(start, JointSample(position, 0, 0), [], [], 1)
            handle = TrajectoryHandle(next(self._ids), trajectory.joints, start, end, notes=planned.notes,
                                      warnings=planned.warnings)
            for joint, spline in splines.items():
                previous = self._owner[joint]
                if previous is not None:
                    previous.finish('superseded', f'replaced by trajectory {handle.id}')
                self._owner[joint] = handle
                kept = [s for s in self._splines[joint] if s.start_time < start]
                self._splines[joint] = [*kept[-1:], spline]
                self._attach(joint, start)
            self._handles.append(handle)
        return handle

    def strategy(self, joint: str) -> str:
        """How the joint is streamed in its current mode (its drive family decides): a
        :class:`StreamStrategy`, or :data:`NOT_STREAMED` when the mode takes no trajectory."""
        return self.axes[joint].stream_strategy() or NOT_STREAMED

    def _attach(self, joint: str, start: float) -> None:
        axis = self.axes[joint]
        if self.strategy(joint) == StreamStrategy.PVT:
            feeder = self._feeders.get(joint)
            if feeder is None:
                feeder = PvtFeeder(lambda t: self.desired(joint, t), lambda: self._end_of(joint),
                                   self.pvt_segment, self.pvt_lookahead, lead=self.cycle_period,
                                   time_unit=axis.pvt_time_unit() or 0.001)
                self._feeders[joint] = feeder
            feeder.start(start)
            axis.set_buffer_feeder(feeder)
        else:
            axis.set_setpoint_source(self._source(joint))

    def _end_of(self, joint: str) -> float | None:
        splines = self._splines[joint]
        return splines[-1].end_time if splines else None

    def now(self) -> float:
        """The stream clock: wall time minus the delay accumulated by stalled cycles."""
        return self.clock() - self.lag

    def _tick(self, t: float) -> float:
        """Stream time of the cycle scheduled at t. A cycle that comes late (the SYNC thread
        stalled) delays the trajectories by the stall, so the next set-point continues from
        the last one instead of jumping (a jump the drive would turn into a following error
        fault). Not while a PVT motion runs: its drive consumes points in real time."""
        if t != self._last_tick:
            late = t - self._last_tick - self.cycle_period
            # one or two lost periods only speed the drive's interpolation up briefly; a
            # longer stall would be a jump
            if self._last_tick and late > STALL_PERIODS * self.cycle_period and not any(
                    not f.ended for f in self._feeders.values()):
                self.lag += late
                self.stalls += 1
            self._last_tick = t
        return t - self.lag

    def _source(self, joint: str) -> Callable[[float], Setpoint | None]:
        """Set-points sampled one cycle ahead: a drive latches a set-point at SYNC and reaches
        it one period later (CSP, linear IP); CSV gets the mean velocity of that period."""
        axis = self.axes[joint]
        period = self.cycle_period

        def sample(t: float) -> Setpoint | None:
            t = self._tick(t)
            if axis.stream_strategy() == StreamStrategy.POSITION_LOOP:
                # the measured position was sampled at the previous SYNC: compare it with the
                # desired position then; feed forward the velocity of the coming period
                then, ahead = self.desired(joint, t - period), self.desired(joint, t + period / 2)
                if then is None or ahead is None:
                    return None
                return Setpoint(position=then.position, velocity=ahead.velocity)
            if axis.stream_strategy() == StreamStrategy.CYCLIC_VELOCITY:
                desired = self.desired(joint, t + period / 2)
                return None if desired is None else Setpoint(velocity=desired.velocity)
            desired = self.desired(joint, t + period)
            return None if desired is None else Setpoint(position=desired.position)
        return sample

    def feeder(self, joint: str) -> PvtFeeder | None:
        return self._feeders.get(joint)

    def on_emcy(self, event: EmcyEvent) -> None:
        """A drive reporting its interpolation buffer ran dry or overflowed: abort the
        stream of its joints and hold them with HALT (safe: the drive decelerates and stays
        enabled; 'resume' clears it). The feeder is detached: on resume the axis then clears
        the points an overflow left queued, so they never run."""
        joints = [j for j, a in self.axes.items()
                  if a.is_stream_fault(event) and self.strategy(j) == StreamStrategy.PVT]
        if not joints:
            return
        self.stop(joints, f'{event}: stream aborted, axis held (HALT)', 'aborted')
        for joint in joints:
            feeder = self._feeders.get(joint)
            if feeder is not None:
                feeder.ended = True
            self.axes[joint].set_buffer_feeder(None)
            self.axes[joint].halt(True)

    # -- stopping and supervision -------------------------------------------------------------
    def stop(self, joints: Iterable[str], reason: str, state: str = 'cancelled', smooth: bool = False) -> None:
        """End the joints' trajectories (with ``state``) and hold them: at once, or (smooth)
        after decelerating from their desired velocity at the axis' stop deceleration."""
        now = self.now()
        with self._lock:
            for joint in joints:
                if joint not in self.axes:
                    continue
                handle = self._owner[joint]
                if handle is not None:
                    handle.finish(state, reason)
                feeder = self._feeders.get(joint)
                at = now if feeder is None or feeder.horizon is None else max(now, feeder.horizon)
                desired = self.desired(joint, at)
                if desired is not None:
                    self._splines[joint] = [*[s for s in self._splines[joint] if s.start_time < at][-1:],
                                            self._stop_spline(joint, at, desired, smooth)]
                self._owner[joint] = None

    def _stop_spline(self, joint: str, at: float, desired: JointSample, smooth: bool) -> JointSpline:
        """Constant deceleration from the desired velocity to rest (a quadratic: the cubic
        Hermite whose end lies at half the velocity times the duration), or a plain hold."""
        if not smooth or abs(desired.velocity) < 1e-9:
            return JointSpline(at, JointSample(desired.position, 0, 0), [], [], 1)
        duration = abs(desired.velocity) / self.axes[joint].stop_deceleration()
        rest = JointSample(desired.position + desired.velocity * duration / 2, 0.0, 0.0)
        return JointSpline(at, JointSample(desired.position, desired.velocity, 0.0), [duration], [rest], 3)

    def check(self, _cycle: int = 0) -> None:
        """Cycle hook: finish trajectories whose time is over, abort those whose axes dropped out."""
        now = self.now()
        if self.lag and not self._handles and all(
                (end := self._end_of(j)) is None or end < now for j in self.axes):
            self.lag = 0.0  # idle again: the next trajectory runs on wall time
        for handle in [h for h in self._handles if not h.finished]:
            if handle.state == 'pending' and now >= handle.start:
                handle.state = 'active'
            for joint in handle.joints:
                axis = self.axes[joint]
                if axis.drive_state is DriveState.ENABLED and axis.available and not axis.halted:
                    continue  # every cycle: no snapshot unless the reason is needed
                snapshot = axis.snapshot()
                if snapshot.drive_state is not DriveState.ENABLED or not snapshot.available:
                    emcy = f'; {snapshot.last_emcy}' if snapshot.last_emcy else ''
                    why = f': {snapshot.message}' if not snapshot.available and snapshot.message else ''
                    reason = f'joint {joint} left operation enabled ({snapshot.state_label}){why}{emcy}'
                    self.stop(handle.joints, reason, 'aborted')
                    break
                if snapshot.halted:  # the driver stopped the stream itself (e.g. following error)
                    self.stop(handle.joints, f'joint {joint} held: {snapshot.message or "HALT"}', 'aborted')
                    break
            else:
                if now >= handle.end:
                    handle.finish('succeeded')
        self._handles = [h for h in self._handles if not h.finished]

    def active(self) -> list[TrajectoryHandle]:
        return [h for h in self._handles if not h.finished]
