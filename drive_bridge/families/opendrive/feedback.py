"""The position of an OPEN drive axis, from what its TPDO carries (shared/drives/opendrive.md §5):
the configured position quantity (16-bit counts, unwrapped here), else the actual velocity
integrated over the TPDO stamps (an estimate the snapshot says it is)."""
from __future__ import annotations

import math

from drive_bridge.families.opendrive.units import Units
from drive_bridge.joint import NodeIo

Key = tuple[int, int]


class PositionFeedback:
    """Unwraps or integrates on each TPDO (the bus' thread); :meth:`position` in SI."""

    def __init__(self, node: NodeIo, units: Units, velocity: Key, position: Key | None) -> None:
        self.node = node
        self.units = units
        self.velocity_key = velocity
        self.position_key = position
        self.counts = 0  # unwrapped counts of the configured quantity
        self.last_raw: int | None = None
        self.estimate = 0.0  # rad: integrated velocity, without a position quantity
        self.last_velocity: tuple[float, float] | None = None  # (SI velocity, stamp)

    @property
    def estimated(self) -> bool:
        return self.position_key is None

    def on_input(self, keys: frozenset[Key], stamp: float) -> None:
        if self.position_key is not None and self.position_key in keys:
            raw = self.node.read(*self.position_key)
            if raw is not None:
                raw = int(raw)
                if self.last_raw is not None:
                    self.counts += (raw - self.last_raw + 0x8000) % 0x10000 - 0x8000
                else:
                    self.counts = raw
                self.last_raw = raw
        elif self.position_key is None and self.velocity_key in keys:
            raw = self.node.read(*self.velocity_key)
            if raw is not None:
                velocity = self.units.velocity_si(raw)
                last = self.last_velocity
                if last is not None and stamp > last[1]:
                    self.estimate += (velocity + last[0]) / 2 * (stamp - last[1])
                self.last_velocity = (velocity, stamp)

    def forget(self) -> None:
        """The node was configured again: the next sample starts anew."""
        self.last_raw = None
        self.last_velocity = None

    def position(self) -> float:
        """SI; NaN before the first sample."""
        if self.position_key is None:
            return self.estimate if self.last_velocity is not None else math.nan
        return self.units.position_si(self.counts) if self.last_raw is not None else math.nan
