"""PVT streaming: a joint's desired trajectory cut into position-velocity-time points that
keep the drive's interpolation buffer fed, without ever overflowing it.

The drive interpolates a cubic (Hermite) between consecutive points, each reached
``time`` ms after the previous one, so sampling the desired trajectory's position and
velocity at whole-ms instants reproduces a cubic spline exactly. Rules kept here:

- at most one point per cycle, and only while the drive reports at least two free
  places (0x60C4:2): one may be in flight, not yet counted by the drive;
- the first point goes out at the trajectory's start (the drive runs a segment as soon as
  it has it), later ones up to ``lookahead`` ahead;
- the motion ends with the final point (velocity 0) followed by a time-0 point, which
  ends the motion (AKD: "write 0 to end the motion").
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from drive_bridge.cia402.axis import Axis
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
    """One joint's PVT stream; installed on its axis with Axis.set_buffer_feeder."""

    def __init__(self, desired: DesiredFn, end: EndFn, segment: float, lookahead: float) -> None:
        if segment <= 0 or abs(segment * 1000 - round(segment * 1000)) > 1e-9:
            raise ValueError(f'PVT segment time must be a positive whole number of ms, got {segment * 1000:g} ms')
        self.desired = desired
        self.end = end
        self.segment = segment
        self.lookahead = max(lookahead, segment)
        self.next_time: float | None = None  # trajectory time of the next point to push
        self.last_time: float | None = None  # time of the last point pushed
        self.ended = True  # no motion in progress (the time-0 end point was sent)
        self.stats = PvtStats()

    @property
    def horizon(self) -> float | None:
        """Until when the drive's motion is committed (the last pushed point)."""
        return None if self.ended else self.last_time

    def start(self, t: float) -> None:
        """A (new) motion begins at t; points continue after what is already committed."""
        if self.ended or self.last_time is None:
            self.next_time = t + self.segment
            self.last_time = t
        self.ended = False

    def on_cycle(self, now: float, axis: Axis) -> None:
        if self.ended or self.next_time is None or self.last_time is None:
            return
        if self.last_time > now + self.lookahead:
            return  # enough queued
        free = axis.interpolation_free_slots()
        if free is not None:
            self.stats.min_free = free if self.stats.min_free is None else min(self.stats.min_free, free)
        if free is None or free < MIN_FREE_TO_SEND:
            self.stats.waits_for_space += 1
            return
        end = self.end()
        if end is not None and self.last_time >= end - 1e-9:
            position, _velocity = self._point(axis, self.last_time)
            axis.push_interpolation_point(position=position, time_ms=0, velocity=0)  # time 0: end of motion
            self.ended = True
            self.stats.motions += 1
            return
        t = self.next_time if end is None else min(self.next_time, end)
        duration_ms = round((t - self.last_time) * 1000)
        if duration_ms <= 0:  # a final piece shorter than 1 ms joins the end point
            t, duration_ms = self.last_time, 0
        position, velocity = self._point(axis, t)
        if t < now:
            self.stats.late_points += 1
        axis.push_interpolation_point(position=position, time_ms=duration_ms, velocity=velocity)
        self.stats.points += 1
        self.last_time = t
        self.next_time = t + self.segment

    def _point(self, axis: Axis, t: float) -> tuple[int, int]:
        """(position counts, velocity counts/s) of the desired trajectory at t."""
        sample = self.desired(t)
        scaling = axis.config.scaling
        if sample is None or math.isnan(sample.position):
            return scaling.position_to_device(axis.commanded_position()), 0
        counts_per_si = 1.0 / scaling.position_factor
        return scaling.position_to_device(sample.position), round(sample.velocity * counts_per_si)
