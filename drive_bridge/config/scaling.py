"""Device units <-> SI for one axis, from either of two forms.

Physical form (ours): encoder counts, gear ratio, direction, rated torque; the
factors are derived. Linear form (ros2_canopen's ``scale_*``/``offset_*`` keys):
the factors are given. One axis uses one form.
"""
from __future__ import annotations

import math

from drive_bridge.config import keys
from drive_bridge.config.errors import Issues, Loc
from drive_bridge.config.reader import Section, describe
from drive_bridge.model import AxisScaling, JointType

RECIPROCAL_TOLERANCE = 1e-9


def parse_scaling(issues: Issues, sec: Section | None, joint_type: JointType, where: Loc,
                  ros_defaults: bool) -> AxisScaling:
    """The axis' scaling; ``where`` locates the axis. Without any scale key the factors are
    1 (or ros2_canopen's defaults for a node that names a ros2_canopen driver), with a warning."""
    if sec is None or not sec.data:
        if ros_defaults:
            issues.warn(where, "no scale keys: ros2_canopen's defaults apply (scale_pos_from_dev, "
                               'scale_vel_from_dev, scale_eff_from_dev = 0.001)')
            return _linear(Section(issues, {}, where))
        issues.warn(where, 'no scaling given: device units are passed through unscaled (all factors 1)')
        return AxisScaling()
    physical = [k for k in sec if k in keys.PHYSICAL_SCALING]
    linear = [k for k in sec if k in keys.LINEAR_SCALING]
    if physical and linear:
        issues.error(sec.where, f'mixes the physical form ({", ".join(physical)}) with the '
                                f'ros2_canopen linear form ({", ".join(linear)}); use one of them')
        return AxisScaling()
    if linear:
        return _linear(sec)
    return _physical(sec, joint_type)


def _reciprocal(sec: Section, to_key: str, from_key: str) -> float:
    """The from-device factor of a to/from pair; both given must be reciprocal."""
    to = sec.get_number(to_key, nonzero=True)
    frm = sec.get_number(from_key, nonzero=True)
    if to is not None and frm is not None:
        if abs(to * frm - 1.0) > RECIPROCAL_TOLERANCE:
            sec.issues.error(sec.loc(from_key),
                             f'{from_key} {frm:g} is not the reciprocal of {to_key} {to:g} '
                             f'({sec.loc(to_key).path}): their product is {to * frm:.10g}, expected 1; '
                             'give only one of them or make them reciprocal')
        return frm
    if frm is not None:
        return frm
    if to is not None:
        return 1.0 / to
    return keys.ROS_SCALING_DEFAULTS[from_key]


def _linear(sec: Section) -> AxisScaling:
    position = _reciprocal(sec, 'scale_pos_to_dev', 'scale_pos_from_dev')
    velocity = _reciprocal(sec, 'scale_vel_to_dev', 'scale_vel_from_dev')
    effort = sec.get_number('scale_eff_from_dev', nonzero=True)
    if effort is None:
        effort = keys.ROS_SCALING_DEFAULTS['scale_eff_from_dev']
    offset_from = sec.get_number('offset_pos_from_dev')
    offset_to = sec.get_number('offset_pos_to_dev')
    derived = None if offset_to is None else -offset_to * position
    offset = 0.0
    if offset_from is not None and derived is not None:
        if not math.isclose(offset_from, derived, rel_tol=RECIPROCAL_TOLERANCE, abs_tol=1e-12):
            sec.issues.error(sec.loc('offset_pos_from_dev'),
                             f'offset_pos_from_dev {offset_from:g} disagrees with offset_pos_to_dev '
                             f'{offset_to:g} ({sec.loc("offset_pos_to_dev").path}), which means '
                             f'{derived:g} in SI; give only one of them')
        offset = offset_from
    elif offset_from is not None:
        offset = offset_from
    elif derived is not None:
        offset = derived
    return AxisScaling(position_factor=position, position_offset=offset,
                       velocity_factor=velocity, effort_factor=effort)


def _direction(sec: Section) -> int:
    value = sec.get('direction', 1)
    if isinstance(value, bool) or value not in (1, -1):
        sec.issues.error(sec.loc('direction'), f'expected 1 or -1, got {describe(value)}')
        return 1
    return int(value)


def _physical(sec: Section, joint_type: JointType) -> AxisScaling:
    revolute = joint_type == 'revolute'
    counts_key, other_key = (('counts_per_revolution', 'counts_per_metre') if revolute
                             else ('counts_per_metre', 'counts_per_revolution'))
    if other_key in sec:
        other_type = 'prismatic' if revolute else 'revolute'
        sec.issues.error(sec.loc(other_key), f'{other_key} is for {other_type} joints; this joint is '
                                             f'{joint_type} (use {counts_key})')
    counts = sec.get_number(counts_key, gt=0)
    gear = sec.get_number('gear_ratio', 1.0, gt=0) or 1.0
    direction = _direction(sec)
    velocity_scale = sec.get_number('velocity_scale', 1.0, gt=0) or 1.0
    offset = sec.get_number('offset', 0.0) or 0.0
    rated = sec.get_number('rated_torque', gt=0)
    per_unit = (2 * math.pi if revolute else 1.0) / counts if counts else 1.0  # SI per device unit at the motor
    position = direction * per_unit / gear
    if rated is None:
        if 'rated_torque' not in sec:
            sec.issues.warn(sec.where, 'no rated_torque: effort is reported as a fraction of the rated '
                                       'torque (factor 0.001 on the per-mille device value)')
        effort = 0.001 * direction
    else:
        effort = direction * rated / 1000.0 * gear
    return AxisScaling(position_factor=position, position_offset=offset,
                       velocity_factor=position * velocity_scale, effort_factor=effort)
