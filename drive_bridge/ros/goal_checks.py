"""What of a control_msgs FollowJointTrajectory goal this bridge can execute, said before it runs.

The bridge drives single-DOF joints (revolute, prismatic) only, so a goal with a multi-DOF part,
or a component tolerance (which bounds a multi-DOF joint), is refused with INVALID_GOAL and the
reason rather than executed in part. The drives report no acceleration, so an acceleration
tolerance cannot be checked and is refused too. Tolerance values follow control_msgs: > 0 is
checked, 0 leaves the server's default (the bridge has none: not checked), -1 lifts a default
(not checked); NaN means nothing and is refused.
"""
from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from typing import Any

from drive_bridge.ros.errors import GoalRefused
from drive_bridge.ros.message_limits import MAX_JOINT_NAMES

SHOWN = 5  # names quoted in a reason; the rest are counted
NAME_CHARS = 40  # of a name quoted (a client may send megabytes)


def _names(names: Sequence[str]) -> str:
    shown = ', '.join(repr(n if len(n) <= NAME_CHARS else n[:NAME_CHARS] + '...') for n in names[:SHOWN])
    return shown + (f' and {len(names) - SHOWN} more' if len(names) > SHOWN else '')


def check_goal(request: Any, bus_joints: Collection[str], invalid_goal: int, invalid_joints: int) -> None:
    """GoalRefused for a goal the bridge cannot execute as asked (before any motion)."""
    multi = request.multi_dof_trajectory
    if multi.joint_names or multi.points:
        raise GoalRefused(invalid_goal, (
            f'multi_dof_trajectory has {len(multi.joint_names)} joint(s) ({_names(list(multi.joint_names))}) and '
            f'{len(multi.points)} point(s): this bridge drives single-DOF joints only (revolute, prismatic); '
            'leave multi_dof_trajectory empty'))
    for field in ('component_path_tolerance', 'component_goal_tolerance'):
        entries = getattr(request, field)
        checked = [e for e in entries if any(not v <= 0 for v in (e.position, e.velocity, e.acceleration))]
        if checked:
            raise GoalRefused(invalid_goal, (
                f'{field} bounds joint(s) {_names([e.joint_name for e in checked])}: component tolerances are '
                'for multi-DOF joints, which this bridge has none of; give the tolerances of single-DOF '
                f'joints in {field.replace("component_", "")}'))
    for field in ('path_tolerance', 'goal_tolerance'):
        entries = getattr(request, field)
        if len(entries) > MAX_JOINT_NAMES:
            raise GoalRefused(invalid_goal, f'{field} has {len(entries)} entries, more than the limit of '
                                            f'{MAX_JOINT_NAMES}')
        unknown = [e.name for e in entries if e.name not in bus_joints]
        if unknown:
            raise GoalRefused(invalid_joints, f'{field} names joint(s) {_names(unknown)}, not joints of this bus '
                                              f'({", ".join(bus_joints)})')
        for entry in entries:
            for kind in ('position', 'velocity', 'acceleration'):
                if math.isnan(getattr(entry, kind)):
                    raise GoalRefused(invalid_goal, f'{field}: {kind} tolerance of {entry.name} is NaN '
                                                    '(give > 0 to check it, 0 or -1 not to)')
            if entry.acceleration > 0:
                raise GoalRefused(invalid_goal, (
                    f'{field}: acceleration tolerance {entry.acceleration:g} of {entry.name} cannot be checked: '
                    'the drives report no acceleration; give 0 (or -1) and bound position and velocity'))


def tolerances(entries: Sequence[Any], joints: Sequence[str], field: str) -> dict[str, float]:
    """Per joint tolerance on ``field`` that is checked (> 0); the last entry of a joint counts."""
    values = {e.name: getattr(e, field) for e in entries}
    return {j: values[j] for j in joints if values.get(j, 0.0) > 0}
