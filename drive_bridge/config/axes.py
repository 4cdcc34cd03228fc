"""The axes of one node, from our ``axes`` list or from ros2_canopen's channel keys.

The object dictionary is not needed here (the number of axes picks the family's
EDS); :func:`check_axis_objects` runs once the OD is loaded.
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from canopen import ObjectDictionary

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import POSITION_MODES, SHORT_NAMES, TORQUE_MODES, VELOCITY_MODES, mode_name, parse_mode
from drive_bridge.config import keys
from drive_bridge.config.errors import Issues, Loc
from drive_bridge.config.odcheck import hex_index, known_name
from drive_bridge.config.reader import Section, describe, to_str
from drive_bridge.config.scaling import parse_scaling
from drive_bridge.families import DriveFamily
from drive_bridge.model import (
    AxisConfig,
    AxisLimits,
    AxisScaling,
    HomingConfig,
    JointType,
    ModeChoice,
    NodeLossConfig,
    PositionLoopConfig,
)

MAX_BRAKE_DELAY = 10.0  # s: on_node_loss.brake_delay
JOINT_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*')
CORE_OBJECTS = (obj.CONTROLWORD, obj.STATUSWORD, obj.MODES_OF_OPERATION, obj.MODES_OF_OPERATION_DISPLAY,
                obj.POSITION_ACTUAL)
_MODE_KINDS: dict[str, tuple[str, frozenset[int] | None]] = {
    'mode': ('csp', None),
    'position_mode': ('csp', POSITION_MODES),
    'velocity_mode': ('csv', VELOCITY_MODES),
    'effort_mode': ('cst', TORQUE_MODES),
}


@dataclass(frozen=True)
class AxisDraft:
    """An axis and where its joint name and slot were given (for bus-wide checks)."""

    axis: AxisConfig
    loc: Loc
    joint_loc: Loc
    slot_loc: Loc


def _joint(issues: Issues, value: Any, loc: Loc) -> str | None:
    name = to_str(issues, value, loc)
    if name is not None and not JOINT_NAME.fullmatch(name):
        issues.error(loc, "expected a joint name (letters, digits and '_', not starting with a digit; "
                          f"'/' between parts), got {describe(name)}")
        return None
    return name


def _mode(sec: Section, key: str, family: DriveFamily) -> int:
    default, allowed = _MODE_KINDS[key]
    default = family.modes.defaults.get(key, default)
    fallback = int(parse_mode(default))
    if key not in sec:
        return fallback
    raw = sec.get(key)
    try:
        code = parse_mode(raw)
    except ValueError:
        names = ', '.join(SHORT_NAMES.values())
        sec.issues.error(sec.loc(key), f'expected a mode name ({names}) or a number -128..127, '
                                       f'got {describe(raw)}')
        return fallback
    looped = key == 'position_mode' and code in VELOCITY_MODES and (
        'position_loop' in sec or family.modes.default_position_loop.enabled)
    if allowed is not None and code >= 0 and code not in allowed and not looped:  # the loop makes pv/csv position modes
        names = ', '.join(mode_name(m) for m in sorted(allowed))
        kind = key.split('_')[0]
        shown = f'{describe(raw)} ({mode_name(code)})' if isinstance(raw, int) else f'{describe(raw)} (mode {code})'
        sec.issues.error(sec.loc(key), f'expected a {kind} mode ({names}) or a manufacturer mode (< 0), '
                                       f'got {shown}')
        return fallback
    if family.modes.accepted is not None and code not in family.modes.accepted:
        names = ', '.join(mode_name(m) for m in sorted(family.modes.accepted))
        sec.issues.error(sec.loc(key), f"family '{family.name}' does not accept mode {mode_name(code)} "
                                       f'(it takes {names}), got {describe(raw)}')
        return fallback
    return int(code)


def _modes(sec: Section, family: DriveFamily) -> dict[str, Any]:
    """AxisConfig's mode keyword arguments (the family's defaults where a key is absent); an
    axis of a family that takes its modes from the drive and names no position mode gets
    its mode picked at boot (``auto_mode``)."""
    modes: dict[str, Any] = {key: _mode(sec, key, family) for key in _MODE_KINDS}
    if family.modes.from_drive and 'mode' not in sec and 'position_mode' not in sec:
        modes['auto_mode'] = ModeChoice()
    return modes


def _take_todo(sec: Section | None) -> list[str]:
    """The places of the keys ``sec`` marks TODO, taken out of it (the rest is parsed as usual)."""
    if sec is None:
        return []
    marked = [k for k, v in sec.data.items() if v == keys.TODO]
    for k in marked:
        del sec.data[k]
    return [sec.loc(k).path for k in marked]


def _placeholder(sec: Section, key: str) -> str | None:
    """'todo' or 'none' for ``key: TODO`` / ``key: none`` (a whole section left open or declined)."""
    value = sec.get(key)
    if value == keys.TODO:
        return 'todo'
    return 'none' if value == keys.NO_SCALING and key == 'scaling' else None


def _scaling(issues: Issues, sec: Section, joint_type: JointType, loc: Loc, todo: list[str]) -> AxisScaling:
    """The axis' scaling. ``scaling: none``: device units on purpose (no warning); TODO (the
    section or any key): device units, and the place goes to ``todo``."""
    kind = _placeholder(sec, 'scaling')
    if kind == 'none':
        return AxisScaling()
    if kind == 'todo':
        todo.append(sec.loc('scaling').path)
        return AxisScaling()
    scaling_section = sec.section('scaling')
    if scaling_section is not None:
        scaling_section.check_keys(keys.SCALING)
    marked = _take_todo(scaling_section)
    if marked:  # the other keys are still checked
        if scaling_section is not None and scaling_section.data:
            parse_scaling(issues, scaling_section, joint_type, loc, ros_defaults=False)
        todo.extend(marked)
        return AxisScaling()
    return parse_scaling(issues, scaling_section, joint_type, loc, ros_defaults=False)


def _limits(sec: Section | None, todo: list[str]) -> AxisLimits:
    if sec is None:
        return AxisLimits(todo=tuple(todo))
    sec.check_keys(keys.LIMITS)
    todo.extend(_take_todo(sec))
    low = sec.get_number('min_position')
    high = sec.get_number('max_position')
    if low is not None and high is not None and low >= high:
        sec.issues.error(sec.loc('max_position'),
                         f'expected a number > min_position ({low:g}), got {describe(sec.get("max_position"))}')
    values = dict(min_position=low, max_position=high,
                  max_velocity=sec.get_number('max_velocity', gt=0),
                  max_acceleration=sec.get_number('max_acceleration', gt=0),
                  max_effort=sec.get_number('max_effort', gt=0))
    reaction = sec.get_str('on_violation', 'halt', keys.VIOLATION_REACTIONS) or 'halt'
    return AxisLimits(**values, on_violation=reaction, todo=tuple(todo),
                      sources={key: 'config' for key, value in values.items() if value is not None})


def _position_loop(sec: Section | None, family: DriveFamily) -> PositionLoopConfig:
    if sec is None:
        return family.modes.default_position_loop
    sec.check_keys(keys.POSITION_LOOP)
    return PositionLoopConfig(gain=sec.get_number('gain', gt=0) or 0.0,
                              following_error=sec.get_number('following_error', gt=0))


def _node_loss(sec: Section | None) -> NodeLossConfig:
    if sec is None:
        return NodeLossConfig()
    sec.check_keys(keys.NODE_LOSS)
    action = sec.get_str('action', 'disable', choices=('disable', 'hold'))
    delay = sec.get_number('brake_delay', ge=0)
    if delay is not None and delay > MAX_BRAKE_DELAY:
        sec.issues.error(sec.loc('brake_delay'), f'expected at most {MAX_BRAKE_DELAY:g} s, got {delay:g}')
        delay = None
    return NodeLossConfig(action='hold' if action == 'hold' else 'disable',
                          brake_delay=NodeLossConfig.brake_delay if delay is None else delay)


def _homing(sec: Section | None) -> HomingConfig:
    if sec is None:
        return HomingConfig()
    sec.check_keys(keys.HOMING)
    return HomingConfig(method=sec.get_int('method', lo=-128, hi=127),
                        speed_search=sec.get_number('speed_search', gt=0),
                        speed_zero=sec.get_number('speed_zero', gt=0),
                        acceleration=sec.get_number('acceleration', gt=0),
                        offset=sec.get_number('offset'))


def _interpolation(sec: Section, family: DriveFamily) -> int:
    """0x60C0 for interpolated position mode: 'linear' (0) or 'pvt' (the family's own code)."""
    choice = sec.get_str('interpolation', family.modes.default_interpolation, choices=('linear', 'pvt'))
    if choice == 'pvt':
        if family.modes.pvt_submode is None:
            sec.issues.error(sec.loc('interpolation'), f"family '{family.name}' has no PVT interpolation "
                                                       "sub-mode; use linear")
            return 0
        return family.modes.pvt_submode
    return 0


def _axis(issues: Issues, value: Any, loc: Loc, position: int, file: str,
          family: DriveFamily) -> AxisDraft | None:
    sec = Section.of(issues, value, loc, 'an axis section (a mapping with at least `joint`)')
    if sec is None:
        return None
    sec.check_keys(keys.AXIS)
    joint = _joint(issues, sec.get('joint'), sec.loc('joint')) if sec.require('joint', 'a joint name') else None
    slot = sec.get_int('slot', position, lo=0, hi=obj.MAX_AXES - 1)
    joint_type: JointType = sec.get_str('type', 'revolute', choices=('revolute', 'prismatic'))  # type: ignore[assignment]
    modes = _modes(sec, family)
    todo: list[str] = []
    if not family.axes.uses_axis_scaling:  # the family's driver scales from its own `drive` settings
        if 'scaling' in sec:
            issues.error(sec.loc('scaling'), f"family '{family.name}' scales from the axis' `drive` settings; "
                                             'remove scaling')
        scaling = AxisScaling()
    else:
        scaling = _scaling(issues, sec, joint_type, loc, todo)
    if _placeholder(sec, 'limits') == 'todo':
        todo.append(sec.loc('limits').path)
        limits = AxisLimits(todo=tuple(todo))
    else:
        limits = _limits(sec.section('limits'), todo)
    if todo:
        issues.warn(loc, f'{", ".join(todo)}: TODO; the joint reports device units where its scaling is TODO, '
                         'and takes no command and no trajectory until every TODO is set')
    axis = AxisConfig(joint=joint or f'<axis {position}>', slot=slot if slot is not None else position,
                      joint_type=joint_type, scaling=scaling, limits=limits,
                      homing=_homing(sec.section('homing')), ip_submode=_interpolation(sec, family),
                      position_loop=_position_loop(sec.section('position_loop'), family),
                      node_loss=_node_loss(sec.section('on_node_loss')), drive=_drive_options(sec, family),
                      where=f'{file}: {loc.path}', **modes)
    slot_loc = sec.loc('slot') if 'slot' in sec else loc
    return AxisDraft(axis, loc, sec.loc('joint'), slot_loc) if joint else None


def _drive_options(sec: Section, family: DriveFamily) -> Mapping[str, Any]:
    """The axis' `drive` settings, validated by its family (errors located at each key)."""
    drive = sec.section('drive', 'a mapping of the drive family\'s own axis settings')
    given = dict(drive.data) if drive is not None else {}
    values, problems = family.parse_axis_options(given)
    for key, message in problems:
        if drive is not None and key in given:
            sec.issues.error(drive.loc(key), message)
        else:  # a required key that is missing: at the section (or the axis) that lacks it
            sec.issues.error(sec.loc('drive') if drive is not None else sec.loc('joint'), f'drive.{key}: {message}')
    return values


def _channel_names(node: Section) -> list[tuple[Loc, str | None]] | None:
    items = node.get_list('channel_names', 'a list of joint names')
    if items is None:
        return None
    return [(loc, _joint(node.issues, value, loc)) for loc, value in items]


def _ros_axes(node: Section, name: str, ros_defaults: bool, file: str,
              family: DriveFamily) -> list[AxisDraft]:
    """ros2_canopen's form: one axis per channel, node-level scale and mode keys,
    per-channel overrides in ``channels``."""
    issues = node.issues
    count = node.get_int('num_channels', lo=1, hi=obj.MAX_AXES)
    names = _channel_names(node)
    if count is not None and names is not None and len(names) != count:
        issues.error(node.loc('channel_names'),
                     f'expected {count} names (num_channels: {count}), got {len(names)}')
    total = count or (len(names) if names else 1)
    if total > obj.MAX_AXES:
        issues.error(node.loc('channel_names'), f'expected at most {obj.MAX_AXES} channels, got {total}')
        return []
    overrides: list[Section | None] = [None] * total
    for index, (loc, value) in enumerate(node.get_list('channels', 'a list of per-channel mappings') or []):
        if index >= total:
            issues.error(loc, f'channel {index} does not exist: the node has {total} channel(s)')
            continue
        overrides[index] = Section.of(issues, value, loc, 'a mapping of scale keys')
        if overrides[index] is not None:
            overrides[index].check_keys(keys.LINEAR_SCALING)  # type: ignore[union-attr]
    modes = _modes(node, family)
    drafts = []
    for index in range(total):
        joint_loc, joint = (names[index] if names and index < len(names)
                            else (node.where, name if total == 1 else f'{name}_{index}'))
        channel = overrides[index]
        where = channel.where if channel is not None else node.where
        data = {k: node.get(k) for k in keys.LINEAR_SCALING if k in node}
        locs = {k: node.loc(k) for k in data}
        if channel is not None:
            data.update(channel.data)
            locs.update({k: channel.loc(k) for k in channel.data})
        scale_section = Section(issues, data, where, locs)
        scaling = parse_scaling(issues, scale_section, 'revolute', where, ros_defaults)
        if joint is None:
            continue
        axis = AxisConfig(joint=joint, slot=index, scaling=scaling, where=f'{file}: {where.path}',
                          ip_submode=((family.modes.pvt_submode or 0) if family.modes.default_interpolation == 'pvt'
                                      else 0),
                          **modes)
        drafts.append(AxisDraft(axis, where, joint_loc, where))
    return drafts


def _form_conflicts(node: Section, family: DriveFamily) -> bool:
    """Reports keys of the form a node does not use; True when the node may have axes."""
    ros_keys = [k for k in keys.ROS_AXIS_FORM if k in node]
    if not family.axes.max_count:
        for key in (['axes'] if 'axes' in node else []) + ros_keys:
            if node.own(key):
                node.issues.error(node.loc(key), f"family '{family.name}' has no CiA 402 axes; remove {key}")
            else:
                node.issues.warn(node.loc(key), f"not used: family '{family.name}' has no CiA 402 axes")
        return False
    if 'axes' in node:
        for key in ros_keys:
            if node.own('axes') and not node.own(key):
                node.issues.warn(node.loc(key), f'not used: the node lists its axes in {node.loc("axes").path}')
            else:
                node.issues.error(node.loc(key), f'cannot be combined with `axes` ({node.loc("axes").path}); '
                                                 'give scaling and modes in each axis section instead')
    return True


def parse_axes(node: Section, name: str, family: DriveFamily, ros_defaults: bool, file: str) -> list[AxisDraft]:
    """The node's axes. A CiA 402 node without `axes` or channel keys is one axis named
    after the node (as ros2_canopen's Cia402Driver)."""
    if not _form_conflicts(node, family):
        return []
    if 'axes' not in node:
        drafts = _ros_axes(node, name, ros_defaults, file, family)
    else:
        items = node.get_list('axes', 'a list of axis sections') or []
        drafts = [d for d in (_axis(node.issues, v, loc, i, file, family) for i, (loc, v) in enumerate(items)) if d]
    seen: dict[int, AxisDraft] = {}
    for draft in drafts:
        slot = draft.axis.slot
        if slot in seen:
            first = seen[slot]
            node.issues.error(draft.slot_loc, f'slot {slot} is already used by {first.slot_loc.path} '
                                              f"(joint '{first.axis.joint}')")
        else:
            seen[slot] = draft
    return drafts


def check_axis_objects(issues: Issues, od: ObjectDictionary, eds_name: str, draft: AxisDraft,
                       family: DriveFamily | None = None) -> bool:
    """The CiA 402 objects the core needs for the axis exist at its slot's offset (False: some do not);
    the position actual object is the one the family names (``axis_objects``: 0x6063 on some drives)."""
    slot = draft.axis.slot
    position = (family.axis_objects(slot).position_actual[0] if family is not None
                else obj.for_axis(obj.POSITION_ACTUAL, slot))
    needed = [obj.for_axis(index, slot) for index in CORE_OBJECTS if index != obj.POSITION_ACTUAL] + [position]
    missing = [index for index in needed if index not in od]
    labels = [f'{hex_index(index)} {known_name(index)}' for index in missing]
    if len(missing) == len(needed):
        issues.error(draft.loc, f'none of the CiA 402 objects of axis slot {slot} are in {eds_name} '
                                f'({", ".join(labels)}); is it a CiA 402 device, and is the slot right?')
        return False
    for label in labels:
        issues.error(draft.loc, f'object {label} is not in {eds_name} (every CiA 402 axis needs it)')
    return not missing
