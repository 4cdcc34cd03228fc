"""What each intent does in the bus process: the Master's and the executor's own API, called
as the ROS layer called it when both ran in one process."""
from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from drive_bridge.busproc.errors import BoundaryError
from drive_bridge.busproc.intents import (
    TEST_HOOKS,
    AxisIntent,
    DirectCommands,
    InjectSetpoint,
    Nmt,
    ParameterCall,
    Query,
    SdoRead,
    SdoWrite,
    TrajectoryChunk,
)
from drive_bridge.busproc.outbox import axis_states
from drive_bridge.busproc.reports import CommandRefused, FeederState
from drive_bridge.errors import RequestRefused
from drive_bridge.joint import JointError, Setpoint
from drive_bridge.master.master import Master
from drive_bridge.streaming.errors import TrajectoryError
from drive_bridge.streaming.executor import TrajectoryExecutor, TrajectoryHandle
from drive_bridge.streaming.trajectory import MAX_TRAJECTORY_POINTS, Trajectory, TrajectoryPoint

ASSEMBLY_TIMEOUT = 5.0  # s a trajectory's chunks may take to arrive before the parts are dropped
MAX_ASSEMBLIES = 4  # trajectories being assembled at once


@dataclass
class _Assembly:
    first: TrajectoryChunk
    points: list[TrajectoryPoint] = field(default_factory=list)
    next_chunk: int = 0
    since: float = field(default_factory=time.monotonic)


class Handlers:
    def __init__(self, master: Master, executor: TrajectoryExecutor, report: Callable[[object], None]) -> None:
        self.master = master
        self.executor = executor
        self.report = report
        self._assemblies: dict[int, _Assembly] = {}

    # -- inline (request-lane reader) -----------------------------------------------------------------
    def commands(self, body: DirectCommands) -> None:
        """Check every joint's command, then apply all (or none); a refusal is reported."""
        axes = self.master.axes
        try:
            for command in body.commands:
                axis = axes.get(command.joint)
                if axis is None:
                    raise JointError(f'unknown joint {command.joint!r}')
                axis.check_command(command.position, command.velocity, command.effort)
        except JointError as exc:
            self.report(CommandRefused(body.topic, str(exc)))
            return
        self.executor.stop([c.joint for c in body.commands], f'replaced by a command on {body.topic}')
        for command in body.commands:
            try:
                axes[command.joint].command(command.position, command.velocity, command.effort)
            except JointError as exc:  # the state changed since the check
                self.report(CommandRefused(body.topic, str(exc)))

    def query(self, body: Query) -> object:
        if body.what == 'snapshot':
            return self.master.snapshot()
        if body.what == 'events':
            return tuple(self.master.events)
        if body.what == 'desired':
            return {joint: self.executor.desired(joint, body.at) for joint in body.joints if joint in self.master.axes}
        if body.what == 'stop_deceleration':
            return {joint: self.master.axes[joint].stop_deceleration() for joint in body.joints
                    if joint in self.master.axes}
        if body.what == 'feeders':
            feeders = {joint: self.executor.feeder(joint) for joint in body.joints}
            return {joint: FeederState(dataclasses.replace(f.stats), f.ended, f.horizon)
                    for joint, f in feeders.items() if f is not None}
        raise ValueError(f'unknown query {body.what!r}')

    def add_chunk(self, chunk: TrajectoryChunk) -> Trajectory | None:
        """Collect a trajectory's chunks; the whole trajectory once the last is in."""
        now = time.monotonic()
        for key in [k for k, a in self._assemblies.items() if now - a.since > ASSEMBLY_TIMEOUT]:
            del self._assemblies[key]
        if not 0 <= chunk.chunk < chunk.chunks or chunk.chunks > MAX_TRAJECTORY_POINTS:
            raise BoundaryError(f'trajectory chunk {chunk.chunk} of {chunk.chunks}')
        assembly = self._assemblies.get(chunk.submission)
        if assembly is None:
            if chunk.chunk != 0:
                raise BoundaryError(f'trajectory {chunk.submission}: chunk {chunk.chunk} without its first')
            if len(self._assemblies) >= MAX_ASSEMBLIES:
                raise BoundaryError(f'{len(self._assemblies)} trajectories are being assembled already')
            assembly = self._assemblies[chunk.submission] = _Assembly(chunk)
        if chunk.chunk != assembly.next_chunk:
            del self._assemblies[chunk.submission]
            raise BoundaryError(f'trajectory {chunk.submission}: chunk {chunk.chunk} after {assembly.next_chunk - 1}')
        assembly.points.extend(chunk.points)
        assembly.next_chunk += 1
        if len(assembly.points) > MAX_TRAJECTORY_POINTS:
            del self._assemblies[chunk.submission]
            raise TrajectoryError(f'{chunk.source}: more than {MAX_TRAJECTORY_POINTS} points')
        if assembly.next_chunk < chunk.chunks:
            return None
        del self._assemblies[chunk.submission]
        first = assembly.first
        return Trajectory(first.joints, tuple(assembly.points), first.start)

    # -- in a worker ------------------------------------------------------------------------------
    def submit(self, source: str, trajectory: Trajectory) -> TrajectoryHandle | None:
        return self.executor.submit(trajectory, source)

    def run(self, body: object) -> object:
        """An intent that may wait on the bus."""
        master = self.master
        if isinstance(body, AxisIntent):
            return self._axis(body)
        if isinstance(body, SdoRead):
            return master.sdo_read(body.node_id, body.index, body.subindex, body.data_type)
        if isinstance(body, SdoWrite):
            return master.sdo_write(body.node_id, body.index, body.subindex, body.value, body.data_type)
        if isinstance(body, Nmt):
            master.nmt(body.command, body.node_id)
            return None
        if isinstance(body, ParameterCall):
            return self._parameter(body)
        if isinstance(body, InjectSetpoint):
            self._inject(body)
            return None
        if isinstance(body, Query) and body.what == 'operational':
            master.wait_until_operational(body.timeout, list(body.joints) or None)
            return axis_states(list(master.axes.values()))  # so the caller's proxies show the booted axes
        raise BoundaryError(f'{type(body).__name__} is not a request the bus process serves')

    def _axis(self, body: AxisIntent) -> object:
        axis = self.master.axes.get(body.joint)
        if axis is None:
            raise JointError(f'unknown joint {body.joint!r}; this bus has {", ".join(self.master.axes)}')
        action = body.action
        if action == 'enable':
            axis.enable(body.timeout)
        elif action == 'disable':
            axis.disable(body.timeout)
        elif action == 'quick_stop':
            axis.quick_stop(body.timeout)
        elif action == 'halt':
            axis.halt(True)
        elif action == 'resume':
            axis.halt(False)
        elif action == 'fault_reset':
            axis.reset_fault(body.timeout)
        elif action == 'set_mode':
            if body.mode is None:
                raise ValueError('set_mode: no mode given')
            axis.set_mode(body.mode, body.timeout)
        elif action == 'home':
            axis.home(body.timeout)
        elif action == 'wait_target_reached':
            axis.wait_target_reached(body.timeout or 0.0)
        else:
            raise BoundaryError(f'unknown axis intent {action!r}')
        return axis_states([axis])  # the answer shows the intent's effect

    def _inject(self, body: InjectSetpoint) -> None:
        if os.environ.get(TEST_HOOKS) != '1':
            raise RequestRefused(f'InjectSetpoint is a test hook: the bus process honours it only with {TEST_HOOKS}=1')
        axis = self.master.axes.get(body.joint)
        if axis is None:
            raise JointError(f'unknown joint {body.joint!r}')
        setpoint = Setpoint(body.position, body.velocity, body.effort)
        axis.set_setpoint_source(lambda _t: setpoint)

    def _parameter(self, body: ParameterCall) -> object:
        access = self.master.parameter_access(body.node_id)
        if body.slot is not None:
            access = access.for_slot(body.slot)
        if body.op == 'read':
            return access.read(body.name, body.drive_object)
        if body.op == 'write':
            return access.write(body.name, body.value_text, body.drive_object)
        if body.op == 'save':
            return access.save(body.drive_object)
        if body.op == 'stores':
            return access.stores(body.name)
        if body.op == 'safety':
            return access.safety(body.name)
        raise BoundaryError(f'unknown parameter operation {body.op!r}')
