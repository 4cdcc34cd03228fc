"""What a joint driver has been asked to move by: the motion intents the cycle turns into
targets or references. They are dropped together (a drop-out, stale inputs, a node reset, a mode
change, a refused set-point), so they live in one record with one :meth:`Intents.drop`."""
from __future__ import annotations

from dataclasses import dataclass, field

from drive_bridge.joint.driver import BufferFeeder, SetpointSource


@dataclass
class Intents:
    """A driver's motion intents (guarded by its lock)."""

    targets: dict[str, int] = field(default_factory=dict)  # device units, by target key name (CiA 402)
    source: SetpointSource | None = None  # sampled each cycle (trajectory streaming)
    feeder: BufferFeeder | None = None  # IP PVT: pushes points while the buffer has room
    ip_point: int | None = None  # IP linear: this cycle's 0x60C1:1, sent every cycle
    loop_target: tuple[float, float] | None = None  # the position loop's (position, velocity), SI

    def drop(self) -> None:
        """Forget every intent: nothing moves the axis until it is commanded again."""
        self.targets.clear()
        self.source = None
        self.feeder = None
        self.ip_point = None
        self.loop_target = None
