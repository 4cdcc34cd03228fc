"""Interpolated position mode of the AKD (0x6060 = 7, enabled by controlword bit 4, statusword
bit 12) [5.3-5.8]: the interpolation buffer, PVT by cubic Hermite and the linear sub-mode.

- PVT (0x60C0 = -2): the axis runs a cubic Hermite from its current point to the next over
  the point's time; the first segment of a motion starts at the actual position (with the
  demand velocity, 0 at rest) at the SYNC that brought the point; a point with time 0 ends
  the motion (the axis stops at the last position; bit 10 at standstill). The running
  segment ending with no next point and no end point is the n705 underflow: the axis brakes
  on CS.DEC to standstill and holds there, enabled.
- Buffer: 0x60C4:1 = 10 places, 9 usable; a point occupies its place until the axis reaches
  it (the point being approached counts).
- Linear (0x60C0 = 0): one point per SYNC reached linearly over 0x60C2; an empty buffer holds
  the last point (no warning); bit 10 is never set.

What the axis provides beyond :class:`~drive_bridge.sim.interfaces.ModeAxis` (``pvt``,
``pvt_velocity``, ``quick_stop_deceleration``, ``warn``, the AKD buffer as ``ip``) is the
AKD axis' (:mod:`drive_bridge.sim.akd.axis`).
"""
from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import CW_OMS_4, SW_OMS_12, SW_OMS_13, SW_TARGET_REACHED
from drive_bridge.sim.akd.objects import EMCY_PVT_UNDERFLOW
from drive_bridge.sim.interfaces import ModeAxis
from drive_bridge.sim.motion import Segment, stop_step
from drive_bridge.sim.opmodes import OpMode


@dataclass(frozen=True)
class PvtPoint:
    position: int  # counts (absolute)
    time_ms: int  # to reach it from the previous point; 0 ends the motion (PVT)
    velocity: int  # counts/s at the point, before the 0x204C scaling


class AkdIpBuffer:
    """The interpolation buffer: 0x60C4:1 places, one of them never usable."""

    overflows = 0  # warnings are the axis' business (kept for Axis402's statusword)

    def __init__(self, size: Callable[[], int]) -> None:
        self._size = size
        self.points: deque[PvtPoint] = deque()
        self.access = True

    def __len__(self) -> int:
        return len(self.points)

    def __bool__(self) -> bool:
        return bool(self.points)

    @property
    def capacity(self) -> int:
        return max(0, self._size() - 1)

    @property
    def free(self) -> int:
        """0x60C4:2: free places."""
        return max(0, self.capacity - len(self.points))

    @property
    def head(self) -> PvtPoint:
        return self.points[0]

    def popleft(self) -> PvtPoint:
        return self.points.popleft()

    def reset(self) -> None:
        self.points.clear()
        self.access = True


@dataclass
class Hermite:
    """Cubic Hermite from (p0, v0) to (p1, v1) over ``duration`` s."""

    p0: float
    v0: float
    p1: float
    v1: float
    duration: float
    elapsed: float = 0.0

    @property
    def position(self) -> float:
        T = self.duration
        s = self.elapsed / T
        s2, s3 = s * s, s * s * s
        return ((2 * s3 - 3 * s2 + 1) * self.p0 + (s3 - 2 * s2 + s) * T * self.v0
                + (-2 * s3 + 3 * s2) * self.p1 + (s3 - s2) * T * self.v1)

    @property
    def velocity(self) -> float:
        T = self.duration
        s = self.elapsed / T
        return ((6 * s * s - 6 * s) * (self.p0 - self.p1) / T + (3 * s * s - 4 * s + 1) * self.v0
                + (3 * s * s - 2 * s) * self.v1)


class AkdInterpolation(OpMode):
    """Interpolated position mode of the AKD: linear or PVT after 0x60C0 (module docstring)."""

    code = Mode.INTERPOLATED_POSITION

    def __init__(self) -> None:
        self.active = False
        self.linear: Segment | None = None
        self.cubic: Hermite | None = None
        self.moving = False  # a PVT motion runs: its end without a next point is an underflow
        self.brake = 0.0  # deceleration while no segment runs (0: the profile ramp)
        self.reached = False  # the end-of-motion point was reached (bit 10 at standstill)

    def enter(self, ax: ModeAxis) -> None:
        self.active = bool(ax.controlword & CW_OMS_4)
        self.abort(0.0)
        self.reached = False

    def abort(self, brake: float) -> None:
        """Leave the running segment; brake with ``brake`` (0: the profile ramp)."""
        self.linear = self.cubic = None
        self.moving = False
        self.brake = brake

    def on_controlword(self, ax: ModeAxis, prev: int, cw: int) -> None:
        active = bool(cw & CW_OMS_4)
        if self.active and not active:
            self.abort(0.0)
        self.active = active

    def resume(self, ax: ModeAxis) -> None:
        self.abort(0.0)

    def on_sync(self, ax: ModeAxis) -> None:
        if not self.active:
            return
        if ax.pvt:  # type: ignore[attr-defined]
            if self.cubic is None:
                self._start(ax)
        else:
            self._consume_linear(ax)

    def step(self, ax: ModeAxis, dt: float) -> None:
        if ax.pvt:  # type: ignore[attr-defined]
            self._step_pvt(ax, dt)
        else:
            self._step_linear(ax, dt)

    # -- linear ---------------------------------------------------------------------------
    def _consume_linear(self, ax: ModeAxis) -> None:
        if ax.ip:
            point = ax.ip.popleft()  # type: ignore[attr-defined]
            self.linear = Segment(ax.dp, ax.limit_target(float(point.position)), ax.interpolation_period())

    def _step_linear(self, ax: ModeAxis, dt: float) -> None:
        if self.active and not ax.sync_driven and (self.linear is None or self.linear.done):
            self._consume_linear(ax)  # no SYNC: the drive's own clock paces the buffer
        if self.linear is None:
            ax.dp, ax.dv = stop_step(ax.dp, ax.dv, ax.profile_deceleration(), dt)
            return
        ax.dp = self.linear.advance(dt)
        ax.dv = self.linear.slope

    # -- PVT ------------------------------------------------------------------------------
    def _start(self, ax: ModeAxis) -> None:
        """First segment of a motion: from the actual position."""
        if not ax.ip:
            return
        ax.dp = ax.p
        self.moving = True
        self._continue(ax, ax.p, ax.dv)

    def _continue(self, ax: ModeAxis, p: float, v: float) -> None:
        """The segment after (p, v): toward the buffer's head, or the end, or an underflow."""
        buffer = ax.ip
        if buffer:
            point = buffer.head  # type: ignore[attr-defined]
            if point.time_ms == 0:
                buffer.popleft()  # type: ignore[attr-defined]
                self.moving, self.reached, self.brake = False, True, 0.0
                ax.dv = 0.0  # stop at the last position
                return
            velocity = ax.pvt_velocity(point.velocity)  # type: ignore[attr-defined]
            self.cubic = Hermite(p, v, float(point.position), velocity, point.time_ms / 1000.0)
            self.reached = False
            return
        if self.moving:
            self.moving = False
            self.brake = ax.quick_stop_deceleration()  # type: ignore[attr-defined]
            ax.warn(EMCY_PVT_UNDERFLOW)  # type: ignore[attr-defined]

    def _step_pvt(self, ax: ModeAxis, dt: float) -> None:
        if self.active and self.cubic is None and not ax.sync_driven:
            self._start(ax)  # no SYNC: the drive's own clock starts the motion
        remaining = dt
        while remaining > 0.0 and self.cubic is not None:
            segment = self.cubic
            used = min(remaining, segment.duration - segment.elapsed)
            segment.elapsed += used
            remaining -= used
            if segment.elapsed >= segment.duration - 1e-12:
                ax.dp, ax.dv = segment.p1, segment.v1
                self.cubic = None
                ax.ip.popleft()  # type: ignore[attr-defined]  # the point is reached: its place is free
                self._continue(ax, segment.p1, segment.v1)
            else:
                ax.dp, ax.dv = segment.position, segment.velocity
        if remaining > 0.0:
            ax.dp, ax.dv = stop_step(ax.dp, ax.dv, self.brake or ax.profile_deceleration(), remaining)

    def status_bits(self, ax: ModeAxis) -> int:
        bits = SW_OMS_12 if self.active else 0
        if ax.fe_active:
            bits |= SW_OMS_13
        if self.reached and self.cubic is None and ax.standstill():
            bits |= SW_TARGET_REACHED
        return bits
