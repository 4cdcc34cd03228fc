"""PVT streaming: a joint's desired trajectory cut into position-velocity-time points that
keep the drive's interpolation buffer fed, without ever overflowing it.

The drive interpolates a cubic (Hermite) between consecutive points, each reached
``time`` units (the family's PVT time unit, e.g. 1 ms) after the previous one, so sampling
the desired trajectory's position and velocity at whole-unit instants reproduces a cubic
spline exactly. Rules kept here:

- at most one point per cycle, and only while the drive reports at least two free
  places (0x60C4:2): one may be in flight, not yet counted by the drive;
- the first point goes out at the trajectory's start (the drive runs a segment as soon as
  it has it), later ones up to ``lookahead`` ahead;
- the motion ends with the final point (velocity 0) followed by a time-0 point, which
  ends the motion.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from drive_bridge.joint import JointDriver
from drive_bridge.streaming.trajectory import JointSample

DesiredFn = Callable[[float], JointSample | None]
EndFn = Callable[[], float | None]
MIN_FREE_TO_SEND = 2  # one free place for the point that may still be in flight


@dataclass
class PvtStats:
    points: int = 0
    motions: int = 0
    waits_for_space: int = 0  # cycles a due point waited for buffer space
    late_points: int = 0  # points pushed after the time the drive needed them
    min_free: int | None = None


class PvtFeeder:
    """One joint's PVT stream; installed on its axis with Axis.set_buffer_feeder.

    Point times are kept in whole time units from the motion's start (the drive's unit;
    variables named ``*_ms`` count these units), so the last segment ends exactly at the
    trajectory's end.
    """

    def __init__(self, desired: DesiredFn, end: EndFn, segment: float, lookahead: float,
                 lead: float = 0.0, time_unit: float = 0.001) -> None:
        per_unit = 1.0 / time_unit
        if segment <= 0 or abs(segment * per_unit - round(segment * per_unit)) > 1e-9:
            raise ValueError(f'PVT segment time must be a positive whole number of {time_unit * 1000:g} ms, '
                             f'got {segment * 1000:g} ms')
        self.desired = desired
        self.end = end
        self.per_unit = per_unit
        self.segment_ms = round(segment * per_unit)
        self.lookahead = max(lookahead, segment)
        self.lead = lead  # a point written now reaches the drive at the next SYNC, this much later
        self.motion_start = 0.0
        self.offset_ms = 0  # ms from the motion start of the last point pushed
        self.ended = True  # no motion in progress (the time-0 end point was sent)
        self.stats = PvtStats()

    @property
    def last_time(self) -> float:
        return self.motion_start + self.offset_ms / self.per_unit

    @property
    def horizon(self) -> float | None:
        """Until when the drive's motion is committed (the last pushed point)."""
        return None if self.ended else self.last_time

    def start(self, t: float) -> None:
        """A motion begins at t; a running one continues (its points are in the drive)."""
        if self.ended:
            self.motion_start, self.offset_ms = t, 0
            self.ended = False

    def on_cycle(self, now: float, axis: JointDriver) -> None:
        if self.ended:
            return
        if self.offset_ms == 0:
            if now + self.lead / 2 < self.motion_start:
                return  # the drive runs a segment as soon as it has it: not before the start
        elif self.last_time > now + self.lookahead:
            return  # enough queued
        free = axis.interpolation_free_slots()
        if free is not None:
            self.stats.min_free = free if self.stats.min_free is None else min(self.stats.min_free, free)
        if free is None or free < MIN_FREE_TO_SEND:
            self.stats.waits_for_space += 1
            return
        end = self.end()
        end_ms = None if end is None else max(0, math.ceil((end - self.motion_start) * self.per_unit - 1e-6))
        if end_ms is not None and self.offset_ms >= end_ms:
            position, _velocity = self._point(axis, self.last_time)
            axis.push_interpolation_point(position=position, time_units=0, velocity=0)  # time 0: end of motion
            self.ended = True
            self.stats.motions += 1
            return
        offset = self.offset_ms + self.segment_ms
        if end_ms is not None:
            offset = min(offset, end_ms)
        t = self.motion_start + offset / self.per_unit
        position, velocity = self._point(axis, t)
        if t < now:
            self.stats.late_points += 1
        duration = offset - self.offset_ms
        if self.offset_ms == 0:  # the drive starts the first segment at this cycle's SYNC (now)
            duration = max(1, round((t - now) * self.per_unit))
        axis.push_interpolation_point(position=position, time_units=duration, velocity=velocity)
        self.stats.points += 1
        self.offset_ms = offset

    def _point(self, axis: JointDriver, t: float) -> tuple[int, int]:
        """(position counts, velocity counts/s) of the desired trajectory at t."""
        sample = self.desired(t)
        scaling = axis.config.scaling
        if sample is None or math.isnan(sample.position):
            return scaling.position_to_device(axis.commanded_position()), 0
        counts_per_si = 1.0 / scaling.position_factor
        return scaling.position_to_device(sample.position), round(sample.velocity * counts_per_si)
