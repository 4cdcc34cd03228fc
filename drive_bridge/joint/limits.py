"""The joint limits a command must keep to, checked the same way by every joint driver."""
from __future__ import annotations

import math

from drive_bridge.model import AxisLimits

TOLERANCE = 1e-12


def limit_problem(limits: AxisLimits, position: float | None = None, velocity: float | None = None,
                  effort: float | None = None) -> str | None:
    """What is wrong with a command in SI (not configured, not finite, beyond a joint limit), None if nothing."""
    if limits.todo:
        return unset_problem(limits)
    for name, value in (('position', position), ('velocity', velocity), ('effort', effort)):
        if value is not None and not math.isfinite(value):
            return f'{name} {value} is not a finite number'
    if position is not None:
        if limits.min_position is not None and position < limits.min_position - TOLERANCE:
            return f'position {position:.6g} is below the limit {limits.min_position:.6g}'
        if limits.max_position is not None and position > limits.max_position + TOLERANCE:
            return f'position {position:.6g} is above the limit {limits.max_position:.6g}'
    if velocity is not None and limits.max_velocity is not None and abs(velocity) > limits.max_velocity + TOLERANCE:
        return f'velocity {velocity:.6g} exceeds the limit {limits.max_velocity:.6g}'
    if effort is not None and limits.max_effort is not None and abs(effort) > limits.max_effort + TOLERANCE:
        return f'effort {effort:.6g} exceeds the limit {limits.max_effort:.6g}'
    return None


def unset_problem(limits: AxisLimits) -> str:
    """Why a joint whose configuration leaves keys TODO takes no command, naming each key."""
    keys = ', '.join(limits.todo)
    verb = 'is' if len(limits.todo) == 1 else 'are'
    return (f'not configured: {keys} {verb} TODO in the bus configuration; set {"it" if verb == "is" else "them"} '
            '(scaling: none streams device units) and restart the bridge')
