"""The joint-driver protocol. The ROS layer and streaming talk to every joint through it;
the CiA 402 axis (``drive_bridge.cia402``) is one implementation, a family may bring another
(a drive without CiA 402 that runs on its own RUN logic)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.joint.snapshot import AxisSnapshot, DriveState
from drive_bridge.joint.strategy import StreamStrategy
from drive_bridge.model import AxisConfig


@dataclass(frozen=True)
class Setpoint:
    """A cyclic command in SI; None fields are not commanded."""

    position: float | None = None
    velocity: float | None = None
    effort: float | None = None


SetpointSource = Callable[[float], Setpoint | None]


class BufferFeeder(Protocol):
    """Feeds a drive's interpolation buffer (PVT), called each cycle while enabled."""

    def on_cycle(self, now: float, axis: JointDriver) -> None: ...


class JointDriver(Protocol):
    """One drive axis mapped to one joint. Intents may block (with a timeout) and raise
    JointError; ``on_cycle`` is called by the master's cycle thread and never blocks."""

    joint: str
    config: AxisConfig
    cycle_period: float

    @property
    def ready(self) -> bool:
        """The driver has seen the drive's state, so its outputs can be decided safely."""
        ...

    @property
    def drive_state(self) -> DriveState: ...

    @property
    def node_id(self) -> int: ...

    @property
    def available(self) -> bool:
        """The node is booted and supervised alive."""
        ...

    @property
    def mode(self) -> int:
        """The mode the bridge requests."""
        ...

    @property
    def halted(self) -> bool:
        """HALT is set, by an intent or by the driver itself (e.g. on a following error)."""
        ...

    def on_cycle(self, now: float) -> None: ...
    def on_node_reset(self) -> None:
        """The node is configured again after a reboot or a loss: drop every intent; the
        drive must not be re-enabled by itself."""
        ...
    def feedback(self) -> tuple[bool, float, float, float, float]:
        """(available, position, velocity, effort, stamp) in SI: the cheap path for joint states."""
        ...
    def snapshot(self) -> AxisSnapshot: ...
    def state_key(self) -> tuple[object, ...]:
        """Changes whenever the state ``~/axis_states`` reports changes (state, mode, flags),
        without building a snapshot: it is compared every cycle."""
        ...
    def last_emcy(self) -> EmcyEvent | None: ...
    def fault_description(self) -> str:
        """Why the axis is in fault and how to clear it ('in fault (last EMCY ...): clear it
        with ~/fault_reset ...'), for refusals; may read the drive's error code (SDO)."""
        ...

    # intents
    def enable(self, timeout: float | None = None) -> None: ...
    def disable(self, timeout: float | None = None) -> None: ...
    def quick_stop(self, timeout: float | None = None) -> None: ...
    def halt(self, on: bool = True) -> None: ...
    def reset_fault(self, timeout: float | None = None) -> None: ...
    def set_mode(self, mode: int | str, timeout: float | None = None) -> None: ...
    def home(self, timeout: float | None = None) -> None: ...
    def check_command(self, position: float | None = None, velocity: float | None = None,
                      effort: float | None = None) -> None: ...
    def command(self, position: float | None = None, velocity: float | None = None,
                effort: float | None = None) -> None: ...
    def wait_target_reached(self, timeout: float) -> None: ...
    def command_field(self) -> str | None:
        """Which value a direct command in the current mode carries ('position', 'velocity',
        'effort'), None when the mode takes none."""
        ...

    # streaming
    def stream_strategy(self) -> StreamStrategy | None:
        """How trajectories are streamed in the current mode, None when the mode takes no
        trajectory."""
        ...
    def check_trajectory(self, has_positions: bool, has_velocities: bool) -> None:
        """Raise JointError when this joint cannot follow a trajectory with these fields
        (e.g. positions only, on a velocity-only drive without position feedback)."""
        ...
    def commanded_position(self) -> float: ...
    def stop_deceleration(self) -> float: ...
    def set_setpoint_source(self, source: SetpointSource | None) -> None: ...
    def set_buffer_feeder(self, feeder: BufferFeeder | None) -> None: ...
    def interpolation_free_slots(self) -> int | None: ...
    def pvt_time_unit(self) -> float | None:
        """Seconds per unit of a PVT point's time (None: no PVT)."""
        ...
    def push_interpolation_point(self, position: int, time_units: int, velocity: int) -> None: ...
    def is_stream_fault(self, event: EmcyEvent) -> bool:
        """The EMCY reports this joint's interpolation buffer ran dry or overflowed."""
        ...

