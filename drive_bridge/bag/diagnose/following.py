"""Following error per axis where the demand (0x6062 position demand, else 0x607A target)
and the actual position (0x6064) are both recorded."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from drive_bridge.bag.diagnose.model import Context, Severity


@dataclass
class AxisFollowing:
    demand: int | None = None
    demand_index: int = 0
    window: int | None = None  # 0x6065 as written in the trace
    times: list[float] = field(default_factory=list)
    errors: list[int] = field(default_factory=list)


class FollowingError:
    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.axes: dict[tuple[int, int], AxisFollowing] = {}

    def _axis(self, node: int, slot: int) -> AxisFollowing:
        axis = self.axes.get((node, slot))
        if axis is None:
            axis = self.axes[(node, slot)] = AxisFollowing()
        return axis

    def position_demand(self, t: float, node: int, slot: int, value: int) -> None:
        """0x6062: what the drive's own profile / interpolation demands."""
        axis = self.axes.get((node, slot)) or self._axis(node, slot)
        axis.demand = value
        axis.demand_index = 0x6062

    def target_position(self, t: float, node: int, slot: int, value: int) -> None:
        """0x607A: the master's set-point, the demand where 0x6062 is not recorded."""
        axis = self.axes.get((node, slot)) or self._axis(node, slot)
        if axis.demand_index != 0x6062:
            axis.demand = value
            axis.demand_index = 0x607A

    def actual(self, t: float, node: int, slot: int, value: int) -> None:
        axis = self.axes.get((node, slot)) or self._axis(node, slot)
        if axis.demand is not None:
            axis.times.append(t - self.ctx.t0)
            axis.errors.append(axis.demand - value)

    def window(self, node: int, slot: int, value: int) -> None:
        self._axis(node, slot).window = value

    def finish(self) -> None:
        for (node, slot), axis in self.axes.items():
            if not axis.errors:
                continue
            worst = max(range(len(axis.errors)), key=lambda i: abs(axis.errors[i]))
            error = axis.errors[worst]
            info = self.ctx.nodes.get(node)
            factor = info.position_factor.get(slot) if info else None
            limit = info.following_limit.get(slot) if info else None
            if axis.window not in (None, 0, 0xFFFFFFFF) and abs(error) > (axis.window or 0):
                self.ctx.add(Severity.WARNING, axis.times[worst] + self.ctx.t0, node,
                             f'axis {slot + 1}: following error {error} counts exceeds the window '
                             f'0x6065 = {axis.window}', 'the axis cannot follow the demand: tuning, load or limits',
                             'following-error', slot=slot)
            elif factor and limit and abs(error * factor) > limit:
                self.ctx.add(Severity.WARNING, axis.times[worst] + self.ctx.t0, node,
                             f'axis {slot + 1}: following error {abs(error * factor):.4g} exceeds the configured '
                             f'{limit:.4g} (position_loop.following_error)',
                             'the axis cannot follow the demand: tuning, load or limits', 'following-error', slot=slot)

    def to_json(self) -> list[dict[str, Any]]:
        out = []
        for (node, slot), axis in sorted(self.axes.items()):
            if axis.errors:
                info = self.ctx.nodes.get(node)
                factor = info.position_factor.get(slot) if info else None
                worst = max(abs(e) for e in axis.errors)
                out.append({'node': node, 'slot': slot, 'joint': self.ctx.joint(node, slot),
                            'samples': len(axis.errors), 'demand_object': f'0x{axis.demand_index:04X}',
                            'max_abs_counts': worst, 'max_abs_si': worst * abs(factor) if factor else None})
        return out
