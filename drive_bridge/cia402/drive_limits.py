"""The drive's own limits, read at boot, for the joint limits its configuration leaves out:
software position limits 0x607D, max profile velocity 0x607F and max motor speed 0x6080, max
acceleration 0x60C5 and deceleration 0x60C6. A value of 0 (or the data type's extreme, which
drives ship as "no limit") is no limit. Velocities are taken in the drive's velocity units
(0x6080 too, as the CiA 402 drives this bridge knows report it), accelerations in velocity
units per second; both limits of a pair give the stricter one.
"""
from __future__ import annotations

from dataclasses import replace

from drive_bridge.cia402 import objects as obj
from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint import NodeIo
from drive_bridge.model import AxisConfig, AxisLimits

SOFTWARE_POSITION_LIMIT = 0x607D
MAX_PROFILE_VELOCITY = 0x607F
MAX_MOTOR_SPEED = 0x6080
MAX_ACCELERATION = 0x60C5
MAX_DECELERATION = 0x60C6
NO_LIMIT = frozenset({-(1 << 31), (1 << 31) - 1, (1 << 32) - 1, 0})


def _read(node: NodeIo, index: int, subindex: int) -> int | None:
    if not node.has_object(index, subindex):
        return None
    try:
        value = node.sdo_read(index, subindex)
    except DriveBridgeError:
        return None
    if isinstance(value, (str, bytes)) or int(value) in NO_LIMIT:
        return None
    return int(value)


def _smallest(node: NodeIo, slot: int, indices: tuple[int, ...]) -> tuple[int, str] | None:
    found = [(abs(v), f'0x{i:04X}') for i in indices
             if (v := _read(node, obj.for_axis(i, slot), 0)) is not None]
    return min(found) if found else None


def with_drive_limits(node: NodeIo, config: AxisConfig, configured: AxisLimits) -> AxisLimits:
    """``configured`` with each missing limit filled from the drive where it has one."""
    scaling, slot = config.scaling, config.slot
    values: dict[str, float | None] = {}
    sources = dict(configured.sources)
    if configured.min_position is None and configured.max_position is None:
        index = obj.for_axis(SOFTWARE_POSITION_LIMIT, slot)
        low, high = _read(node, index, 1), _read(node, index, 2)
        if low is not None and high is not None and low < high:
            ends = sorted((scaling.position_to_si(low), scaling.position_to_si(high)))
            values.update(min_position=ends[0], max_position=ends[1])
            sources.update(min_position='drive 0x607D:1', max_position='drive 0x607D:2')
    for key, indices in (('max_velocity', (MAX_PROFILE_VELOCITY, MAX_MOTOR_SPEED)),
                         ('max_acceleration', (MAX_ACCELERATION, MAX_DECELERATION))):
        if getattr(configured, key) is not None:
            continue
        found = _smallest(node, slot, indices)
        if found is not None:
            values[key] = found[0] * abs(scaling.velocity_factor)
            sources[key] = f'drive {found[1]}'
    return replace(configured, **values, sources=sources)  # type: ignore[arg-type]


def describe(joint: str, limits: AxisLimits) -> str:
    """The start-up line: each limit in force and where it came from."""
    parts = []
    if limits.min_position is not None or limits.max_position is not None:
        where = limits.sources.get('min_position') or limits.sources.get('max_position', '')
        parts.append(f'position {limits.min_position:.6g}..{limits.max_position:.6g} ({where})'
                     if limits.min_position is not None and limits.max_position is not None
                     else f'position {limits.min_position}..{limits.max_position} ({where})')
    for key, name in (('max_velocity', 'velocity'), ('max_acceleration', 'acceleration'), ('max_effort', 'effort')):
        value = getattr(limits, key)
        if value is not None:
            parts.append(f'{name} {value:.6g} ({limits.sources.get(key, "config")})')
    text = f'joint {joint}: limits checked: {", ".join(parts) or "none"}; a set-point beyond them holds the axis ' \
           f'({limits.on_violation.replace("_", " ")})'
    if limits.max_velocity is None:
        text += ('; no velocity limit (limits.max_velocity not set, the drive reports none in 0x607F/0x6080): '
                 'its trajectories stream with a warning, their speed unchecked')
    return text


def stop_deceleration(node: NodeIo, config: AxisConfig) -> float:
    """Deceleration (SI, > 0) for a controlled stop: the joint's configured max_acceleration,
    else the drive's profile deceleration 0x6084 (within the drive's own maximum), else that
    maximum, else 1 unit/s^2."""
    limits = config.limits
    # the configured limit; one read from the drive's maximum (0x60C5) only caps its profile's
    configured = limits.sources.get('max_acceleration', 'config') == 'config'
    value = limits.max_acceleration if configured else None
    key = (obj.for_axis(obj.PROFILE_DECELERATION, config.slot), 0)
    if value is None and node.has_object(*key):
        try:
            raw = node.sdo_read(*key)
            value = None if isinstance(raw, (str, bytes)) else abs(int(raw) * config.scaling.velocity_factor)
        except Exception:
            value = None
    if value and limits.max_acceleration:
        value = min(value, limits.max_acceleration)
    return value if value else (limits.max_acceleration or 1.0)
