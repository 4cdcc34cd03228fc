"""How a joint's trajectories reach its drive, in the joint's current mode.

A joint driver answers it (its profile or family decides), streaming acts on it, and it
crosses to the node in every axis snapshot. A ``str`` enum: each member equals, and prints
as, the string the bridge has always used for it ('cyclic', 'pvt', ...), so logs, messages
and comparisons with those strings stay as they were.
"""
from __future__ import annotations

from enum import Enum


class StreamStrategy(str, Enum):
    """A streaming strategy (CiA 402 modes, or the bridge's own position loop)."""

    CYCLIC = 'cyclic'  # cyclic synchronous position (CSP): one position set-point per SYNC
    CYCLIC_VELOCITY = 'cyclic-velocity'  # cyclic synchronous velocity (CSV): one velocity per SYNC
    IP_LINEAR = 'ip-linear'  # interpolated position, linear sub-mode: one position per SYNC
    PVT = 'pvt'  # interpolated position, the family's PVT sub-mode: points into the drive's buffer
    POSITION_LOOP = 'position-loop'  # a velocity mode closed by the bridge's position loop

    def __str__(self) -> str:
        return str(self.value)


NOT_STREAMED = 'none'
"""What the executors' ``strategy(joint)`` says of a joint whose mode takes no trajectory."""
