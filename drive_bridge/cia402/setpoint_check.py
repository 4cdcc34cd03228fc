"""The CiA 402 axis' last check of its commanded targets each cycle (``joint.setpoint_guard``),
in device units as they are about to be written: which targets a mode carries, which of them
change under the bridge's control each cycle (cyclic modes, linear IP, the position loop) and
which only name a goal the drive ramps to itself (pp, pv, pt, homing)."""
from __future__ import annotations

from collections.abc import Mapping

from drive_bridge.cia402.modes import CYCLIC_MODES, Mode
from drive_bridge.joint.setpoint_guard import SetpointGuard
from drive_bridge.model import AxisConfig

KIND = {'target_position': 'position', 'target_velocity': 'velocity', 'target_torque': 'effort'}


def cyclic(mode: int, looped: bool) -> bool:
    """The bridge makes this mode's motion set-point by set-point (its change is checked)."""
    return mode in CYCLIC_MODES or mode == Mode.INTERPOLATED_POSITION or looped


def check_targets(guard: SetpointGuard, config: AxisConfig, mode: int, looped: bool,
                  targets: Mapping[str, int], ip_point: int | None, now: float) -> str | None:
    """The first problem of this cycle's commanded targets (None: they may go out)."""
    scaling, limits = config.scaling, config.limits
    rate = cyclic(mode, looped)
    values: list[tuple[str, float, float]] = []
    if ip_point is not None and mode == Mode.INTERPOLATED_POSITION:
        values.append(('position', scaling.position_to_si(ip_point), abs(scaling.position_factor)))
    for name, raw in targets.items():
        kind = KIND.get(name)
        if kind is None or (kind == 'position' and mode == Mode.INTERPOLATED_POSITION):
            continue
        if kind == 'position':
            values.append((kind, scaling.position_to_si(raw), abs(scaling.position_factor)))
        elif kind == 'velocity':
            values.append((kind, scaling.velocity_to_si(raw), abs(scaling.velocity_factor)))
        else:
            values.append((kind, scaling.effort_to_si(raw), abs(scaling.effort_factor)))
    for kind, value, resolution in values:
        problem = guard.check(limits, kind, value, now, resolution, rate)
        if problem is not None:
            return problem
    return None


def seed_hold(guard: SetpointGuard, config: AxisConfig, targets: Mapping[str, int], now: float) -> None:
    """Targets written without the check (holding the measured position, zeros while idle)."""
    scaling = config.scaling
    position = targets.get('target_position')
    guard.seed('position', scaling.position_to_si(position) if position is not None else None, now)
    velocity = targets.get('target_velocity')
    guard.seed('velocity', scaling.velocity_to_si(velocity) if velocity is not None else None, now)
