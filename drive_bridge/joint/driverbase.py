"""What every joint driver shares, whatever its drive speaks: the lock its intents wait on and the
wait itself, how its errors name the axis, the HALT and message it reports, its motion intents,
the command dead-man, the outputs it writes (each once per change), the bridge's position loop
fed from a stream, and the snapshot's common fields.

The CiA 402 axis and a family's driver without CiA 402 (the OPEN drive's RUN logic) subclass
:class:`JointDriverBase`, a documented extension point (docs/families.md); each adds its state
machine, its feedback and its references. Every member is public: a family's subclass touches
no private member of the core.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.joint.errors import JointError
from drive_bridge.joint.intents import Intents
from drive_bridge.joint.limits import limit_problem
from drive_bridge.joint.nodeio import NodeIo
from drive_bridge.joint.position_loop import PositionLoop
from drive_bridge.joint.setpoint_guard import SetpointGuard
from drive_bridge.joint.snapshot import AxisSnapshot
from drive_bridge.model import AxisConfig, Timeouts

Key = tuple[int, int]


class CommandDeadMan:
    """Direct commands and streamed set-points feed it; silent for the node's ``command_timeout``
    the driver holds and the snapshot says the command is stale."""

    def __init__(self) -> None:
        self.last = 0.0  # monotonic time of the last command / set-point; 0: none to supervise
        self.stale = False

    def fed(self) -> None:
        self.last = time.monotonic()
        self.stale = False

    def clear(self) -> None:
        self.last, self.stale = 0.0, False

    def expired(self, timeout: float) -> bool:
        """True once, on the cycle the commands have been silent for ``timeout`` (then stale)."""
        if self.last and not self.stale and time.monotonic() - self.last > timeout:
            self.stale = True
            return True
        return False


class JointDriverBase:
    """The plumbing of one drive axis mapped to one joint (``drive_bridge.joint.JointDriver``);
    a subclass says how it names its place (:meth:`placement`), its state (:meth:`state_text`)
    and its last EMCY, and raises its own ``error``."""

    error: type[JointError] = JointError
    liveness = 'heartbeat'  # how the node's liveness is supervised (said when it is not available)

    def __init__(self, node: NodeIo, config: AxisConfig, timeouts: Timeouts, cycle_period: float) -> None:
        self.node = node
        self.config = config
        self.timeouts = timeouts
        self.cycle_period = cycle_period  # s
        self.joint = config.joint
        self.lock = threading.Condition()  # held around each cycle and intent; notified on new state
        self.intents = Intents()
        self.deadman = CommandDeadMan()
        self.guard = SetpointGuard(cycle_period)  # the last check of each cycle's set-point
        self.loop: PositionLoop | None = None  # the bridge's position loop (StreamStrategy.POSITION_LOOP)
        self.halted = False  # HALT: by an intent, or by the driver itself (a following error)
        self.message = ''  # what the snapshot says of the axis
        self.written: dict[Key, int | float] = {}  # the outputs as last written

    # -- what a driver says of itself ------------------------------------------------------------
    def placement(self) -> str:
        """Where the axis sits, after its node in :meth:`where` ('slot 0')."""
        return f'slot {self.config.slot}'

    def state_text(self) -> str:
        """The drive's state, said when an intent times out."""
        raise NotImplementedError

    def last_emcy(self) -> EmcyEvent | None:
        raise NotImplementedError

    @property
    def node_id(self) -> int:
        return self.node.node_id

    @property
    def available(self) -> bool:
        return self.node.available

    def where(self) -> str:
        """'axis ... (node ..., slot ...)': how messages name the axis."""
        return f'axis {self.joint!r} (node {self.node.node_id} {self.node.name}, {self.placement()})'

    def say(self, message: str) -> None:
        with self.lock:
            self.message = message

    # -- intents (any thread but the CAN Notifier) -----------------------------------------------
    def require_available(self) -> None:
        if not self.node.available:
            raise self.error(f'{self.where()}: node not available (NMT {self.node.nmt_state}); '
                             f'wait for it to boot or check its {self.liveness}')

    def require_alive(self) -> None:
        """For a command: the node is available (no advice, the command is refused at once)."""
        if not self.node.available:
            raise self.error(f'{self.where()}: node not available (NMT {self.node.nmt_state})')

    def check_limits(self, position: float | None, velocity: float | None, effort: float | None) -> None:
        """A command beyond the joint's limits is refused (``error``)."""
        problem = limit_problem(self.config.limits, position, velocity, effort)
        if problem:
            raise self.error(f'{self.where()}: {problem}')

    def wake(self) -> None:
        """New state arrived (the bus' thread): intents waiting on it look again."""
        with self.lock:
            self.lock.notify_all()

    def wait(self, done: Callable[[], bool], timeout: float, what: str) -> None:
        """Until ``done()`` (asked under the lock on each new state), else ``error`` after ``timeout``."""
        deadline = time.monotonic() + timeout
        with self.lock:
            while not done():
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise self.error(f'{self.where()}: {what} not reached after {timeout * 1000:.0f} ms '
                                     f'({self.state_text()})')
                self.lock.wait(min(remaining, 0.05))

    # -- outputs ------------------------------------------------------------------------------------
    def put(self, key: Key, value: int | float) -> None:
        """Write ``value`` unless it is the one last written there (the process image keeps it)."""
        if self.written.get(key) != value:
            self.written[key] = value
            self.node.write(*key, value)

    # -- the bridge's position loop ------------------------------------------------------------------
    def follow_position(self, position: float, velocity: float | None, actual_velocity: float) -> None:
        """A position set-point for the bridge's loop (under the lock): a stream that starts
        from rest or motion starts the loop and the rate check at the drive's actual velocity."""
        if self.intents.loop_target is None and self.loop is not None:
            self.loop.reset(actual_velocity)
            self.guard.rebase('velocity', actual_velocity)
        self.intents.loop_target = (position, velocity or 0.0)
        self.deadman.fed()

    def loop_velocity(self, measured: float, held: str, resolution: float = 0.0) -> float | None:
        """One step of the loop toward the intents' loop target (SI, under the lock); None when
        the following error went beyond its limit while a trajectory streams (a direct command
        is a step on purpose): the stream is stopped, the axis halted and says ``held`` how."""
        assert self.loop is not None and self.intents.loop_target is not None
        position, feed_forward = self.intents.loop_target
        out = self.loop.step(position, feed_forward, measured, self.cycle_period, resolution)
        if out.exceeded and self.intents.source is not None:
            self.halted = True
            self.intents.source = None
            self.intents.loop_target = None
            self.loop.reset()
            self.message = (f'following error {out.error:.4g} beyond the position loop limit '
                            f'{self.config.position_loop.following_error:.4g}: stream aborted, axis held ({held})')
            return None
        return out.velocity

    # -- state ------------------------------------------------------------------------------------
    def snapshot_of(self, **fields: Any) -> AxisSnapshot:
        """A snapshot with the fields every driver fills alike, and the driver's own."""
        return AxisSnapshot(joint=self.joint, node_id=self.node.node_id, node_name=self.node.name,
                            slot=self.config.slot, nmt_state=self.node.nmt_state, halted=self.halted,
                            command_stale=self.deadman.stale, last_emcy=self.last_emcy(), **fields)
