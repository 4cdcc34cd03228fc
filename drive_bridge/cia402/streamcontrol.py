"""How a CiA 402 axis takes a trajectory: which streaming the requested mode allows (the family
decides; the bridge's position loop in a velocity mode), the set-point source sampled each
cycle, the interpolation buffer a PVT feeder fills, the position it is commanded to and its
controlled-stop deceleration. A mixin of :class:`~drive_bridge.cia402.modecontrol.ModeControl`
(the per-mode control), on the state the :class:`~drive_bridge.cia402.axis.Axis` owns.
"""
from __future__ import annotations

import math
import time

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.drive_limits import stop_deceleration
from drive_bridge.cia402.errors import AxisError
from drive_bridge.cia402.interpolation import InterpolationObjects
from drive_bridge.cia402.modes import VELOCITY_MODES, Mode, mode_name
from drive_bridge.cia402.profile import Cia402Profile, PvtRecord, standard_strategy
from drive_bridge.cia402.quirks import AxisQuirks
from drive_bridge.cia402.setpoint_check import SetpointChecks
from drive_bridge.cia402.statemachine import State
from drive_bridge.joint import BufferFeeder, SetpointSource
from drive_bridge.joint.strategy import StreamStrategy


class StreamControl(SetpointChecks):
    """Trajectory streaming of one axis (its intents' source and feeder, guarded by the lock)."""

    # shared with the state-machine driver (set in Axis.__init__)
    profile: Cia402Profile | None
    pvt: PvtRecord | None
    key: dict[str, tuple[int, int]]
    quirks: AxisQuirks
    interpolation: InterpolationObjects
    _stop_deceleration: float | None
    _mode_problem: str  # why the axis has no usable mode ('' when it has one)

    # provided by the state-machine driver
    @property
    def state(self) -> State:
        raise NotImplementedError

    def read(self, name: str) -> int | float | None:
        raise NotImplementedError

    def _require_mode(self) -> None:
        if self._mode_problem:
            raise AxisError(f'{self.where()}: {self._mode_problem}')

    def _clear_unfed_buffer(self) -> None:
        """Clear the drive's interpolation buffer (0x60C4:6 = 0, 1) if the axis is in IP and
        no stream feeds it: nothing the bridge still wants is queued there."""
        with self.lock:
            intents = self.intents
            unfed = self._mode == Mode.INTERPOLATED_POSITION and intents.feeder is None and intents.source is None
        if unfed:
            self.interpolation.clear_buffer()

    def stop_deceleration(self) -> float:
        """Deceleration (SI, > 0) for a controlled stop, derived once: the family's (its quirks),
        else the configured max_acceleration, else the drive's profile deceleration 0x6084."""
        if self._stop_deceleration is None:
            self._stop_deceleration = self.quirks.stop_deceleration()
        if self._stop_deceleration is None:
            self._stop_deceleration = stop_deceleration(self.node, self.config)
        return self._stop_deceleration

    def set_buffer_feeder(self, feeder: BufferFeeder | None) -> None:
        """A stream that pushes interpolation points (PVT) while the drive's buffer has room."""
        with self.lock:
            self.intents.feeder = feeder
            self.intents.source = None if feeder is not None else self.intents.source

    def interpolation_free_slots(self) -> int | None:
        """Free places in the drive's interpolation buffer (0x60C4:2), None if unknown."""
        value = self.read('ip_free')
        return None if value is None else int(value)

    def pvt_time_unit(self) -> float | None:
        """Seconds per unit of a PVT point's time (None: the family has no PVT)."""
        return self.pvt.time_unit if self.pvt is not None else None

    def push_interpolation_point(self, position: int, time_units: int, velocity: int) -> None:
        """Write one PVT point (device units) into the family's record: velocity, time, then
        position, sent together this cycle; the drive buffers it at the next SYNC."""
        if self.pvt is None:
            raise AxisError(f'{self.where()}: the drive family has no PVT interpolation')
        if not self._pvt_point_allowed(position, time_units, velocity):
            return
        self.node.write(*self.pvt.velocity, velocity)
        self.node.write(*self.pvt.time, time_units)
        self.node.write(*self.pvt.position, position)

    def check_trajectory(self, has_positions: bool, has_velocities: bool) -> None:
        """A CiA 402 axis follows any trajectory its streaming mode takes; a velocity-only
        one only in a velocity mode (its positions are integrated, not measured)."""
        self.quirks.check_trajectory(has_positions, has_velocities)
        self._require_mode()
        if not has_positions and self.stream_strategy() != StreamStrategy.CYCLIC_VELOCITY:
            raise AxisError(f'{self.where()}: a trajectory without positions needs a velocity streaming '
                            f'mode (csv); mode is {mode_name(self._mode)}')

    def stream_strategy(self) -> StreamStrategy | None:
        """How trajectories are streamed in the requested mode (the family decides); a
        velocity mode with the axis' ``position_loop`` set streams through the bridge's loop."""
        if self.config.position_loop.enabled and self._mode in VELOCITY_MODES:
            return StreamStrategy.POSITION_LOOP
        if self.profile is not None:
            return self.profile.streaming_strategy(self._mode, self.config.ip_submode)
        return standard_strategy(self._mode, self.config.ip_submode, None)

    def is_stream_fault(self, event: EmcyEvent) -> bool:
        """The family says this EMCY reports an interpolation buffer underflow/overflow."""
        return (self.profile is not None and event.node_id == self.node.node_id
                and self.profile.is_stream_fault(event))

    def commanded_position(self) -> float:
        """SI position the drive is commanded to now (last target written), else the actual."""
        sent = self.quirks.commanded_position()
        if sent is not None:
            return self.config.scaling.position_to_si(sent)
        target = self.written.get(self.key['target_position'])
        if target is None or self.state is not State.OPERATION_ENABLED:
            target = self.read('position')
        return self.config.scaling.position_to_si(target) if target is not None else math.nan

    def set_setpoint_source(self, source: SetpointSource | None) -> None:
        """A function sampled each cycle (trajectory streaming); None stops sampling."""
        with self.lock:
            self.intents.source = source
            if source is None:
                self.deadman.last = time.monotonic()  # the dead-man then holds if nothing follows
