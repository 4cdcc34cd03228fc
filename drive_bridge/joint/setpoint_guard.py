"""The last check before a set-point goes out: whatever produced it (a trajectory, a direct
command, the bridge's position loop, a bug), a value beyond the joint's limits, or a change
from the previous cycle's set-point larger than the limits allow in the time between them,
is never written. The driver then holds the axis (HALT, or quick stop where the axis'
``limits.on_violation`` says so) and reports the cause.

What a change may be: a position set-point moves at most ``max_velocity`` x the time since
the last one, a velocity set-point at most ``max_acceleration`` x that time, each with
``MARGIN`` and two device units of rounding. Effort has no rate limit (the configuration
has none to give). Modes whose drive makes its own profile (pp, pv, pt) only get the
absolute check: their drive ramps to the target.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from drive_bridge.model import AxisLimits

MARGIN = 0.05  # relative: sampling rounding of a trajectory planned right at the limit
ROUNDING_UNITS = 2.0  # device units a set-point may differ by through rounding alone
RATE_OF = {'position': 'max_velocity', 'velocity': 'max_acceleration'}


@dataclass
class SetpointGuard:
    """One joint's last written set-points (SI, with the cycle time) and the check."""

    cycle_period: float
    last: dict[str, tuple[float, float]] = field(default_factory=dict)  # kind -> (value, time)

    def seed(self, kind: str, value: float | None, now: float) -> None:
        """A value written without the check (holding the measured position, 0 when idle): the
        next commanded set-point is measured against it."""
        if value is None or not math.isfinite(value):
            self.last.pop(kind, None)
        else:
            self.last[kind] = (value, now)

    def rebase(self, kind: str, value: float) -> None:
        """The next ``kind`` set-point is measured from ``value`` (the drive's actual velocity
        when the bridge's position loop starts from it), at the last set-point's time."""
        previous = self.last.get(kind)
        if previous is not None and math.isfinite(value):
            self.last[kind] = (value, previous[1])

    def forget(self) -> None:
        self.last.clear()

    def check(self, limits: AxisLimits, kind: str, value: float, now: float, resolution: float = 0.0,
              rate: bool = True) -> str | None:
        """What is wrong with writing ``value`` (SI) as this cycle's ``kind`` set-point (None:
        nothing; it is then remembered). ``resolution``: SI of one device unit; ``rate``:
        also check the change since the last one (cyclic modes)."""
        problem = _absolute(limits, kind, value, resolution)
        if problem is None and rate:
            problem = self._change(limits, kind, value, now, resolution)
        if problem is None:
            self.last[kind] = (value, now)
        return problem

    def step_problem(self, limits: AxisLimits, kind: str, value: float, resolution: float = 0.0) -> str | None:
        """Why a direct command of ``value`` would be refused by the next cycle (a step from the
        set-point in force larger than one cycle allows), None if it would pass; nothing recorded."""
        previous = self.last.get(kind)
        if previous is None:
            return None
        problem = self._change(limits, kind, value, previous[1] + self.cycle_period, resolution)
        return None if problem is None else (f'{problem}: a step the next cycle would refuse; command a ramp '
                                             '(or a trajectory)')

    def _change(self, limits: AxisLimits, kind: str, value: float, now: float, resolution: float) -> str | None:
        key = RATE_OF.get(kind)
        previous = self.last.get(kind)
        rate = getattr(limits, key) if key else None
        if rate is None or previous is None:
            return None
        before, then = previous
        elapsed = max(now - then, self.cycle_period)
        allowed = rate * elapsed * (1 + MARGIN) + ROUNDING_UNITS * resolution
        change = value - before
        if abs(change) <= allowed:
            return None
        return (f'{kind} set-point {value:.6g} is {abs(change):.6g} from the last one ({before:.6g}) within '
                f'{elapsed * 1000:.3g} ms: beyond limits.{key} {rate:.6g} (at most {allowed:.6g})')


def _absolute(limits: AxisLimits, kind: str, value: float, resolution: float) -> str | None:
    if not math.isfinite(value):
        return f'{kind} set-point {value} is not a finite number'
    slack = ROUNDING_UNITS * resolution + 1e-9
    if kind == 'position':
        if limits.min_position is not None and value < limits.min_position - slack:
            return f'position set-point {value:.6g} is below limits.min_position {limits.min_position:.6g}'
        if limits.max_position is not None and value > limits.max_position + slack:
            return f'position set-point {value:.6g} is above limits.max_position {limits.max_position:.6g}'
        return None
    bound = limits.max_velocity if kind == 'velocity' else limits.max_effort
    name = 'max_velocity' if kind == 'velocity' else 'max_effort'
    if bound is not None and abs(value) > bound * (1 + 1e-6) + slack:
        return f'{kind} set-point {value:.6g} exceeds limits.{name} {bound:.6g}'
    return None
