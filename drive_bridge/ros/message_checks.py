"""Non-finite numbers in a client's message are refused, naming the field, never ignored and
never taken for something else: a ``JointState`` command with ``inf`` is not "not commanded"
(NaN is, by topic_based_ros2_control's convention). A goal's tolerances: ``ros/goal_checks.py``."""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

from drive_bridge.ros.errors import NonFinite


def _first_bad(values: Iterable[float], allow_nan: bool) -> tuple[int, float] | None:
    for i, value in enumerate(values):
        if math.isinf(value) or (not allow_nan and math.isnan(value)):
            return i, value
    return None


def check_joint_commands(names: Sequence[str], fields: dict[str, Sequence[float]]) -> None:
    """``~/joint_commands``: NaN marks a value not commanded; an infinity is refused."""
    for field, values in fields.items():
        bad = _first_bad(values, allow_nan=True)
        if bad is not None:
            i, value = bad
            joint = names[i] if i < len(names) else f'#{i}'
            raise NonFinite(f'{field}[{i}] ({joint}) is {value}: not a finite number (NaN marks "not '
                            'commanded"; an infinity is refused)')


def check_trajectory_points(points: Sequence[Any]) -> None:
    """The fields of JointTrajectoryPoint the core does not read (effort) are checked here;
    positions, velocities and accelerations are checked, named, by the core's validation."""
    for i, point in enumerate(points):
        bad = _first_bad(point.effort, allow_nan=False)
        if bad is not None:
            raise NonFinite(f'point {i}: effort[{bad[0]}] is {bad[1]}: not a finite number')


def check_float(field: str, value: float) -> None:
    if not math.isfinite(value):
        raise NonFinite(f'{field} is {value}: not a finite number')
