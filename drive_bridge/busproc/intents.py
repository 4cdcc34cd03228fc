"""Node process -> bus process: what the node asks of the bus, one record type per intent.

Every record travels inside a :class:`Request` with an id that its answer (a
``reports.Reply`` or ``reports.Failure``) names. Two lanes carry them:

- the **stop lane** carries :class:`Stop` only (quick stop, halt, disable, and ending
  trajectories: goal cancel, deactivation). The bus process reads it in a thread of its own
  and acts at once: a stop never waits behind an SDO, a trajectory chunk or a parameter.
- the **request lane** carries everything else. Requests that wait on the bus (SDO, NMT,
  parameters, axis intents) run in a bounded worker pool; more than it holds are refused
  (``busy``) at once.

Bounds: a message is at most ``wire.MAX_MESSAGE`` bytes; a trajectory crosses in chunks of at
most :data:`CHUNK_POINTS` points (:class:`TrajectoryChunk`), fewer for a trajectory of many
joints (:func:`chunk_points`: a chunk's points stay under :data:`CHUNK_BYTES`), at most
``streaming.trajectory.MAX_TRAJECTORY_POINTS`` in all.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from drive_bridge.config.source import ConfigSource
from drive_bridge.streaming.trajectory import TrajectoryPoint

CHUNK_POINTS = 500  # points per trajectory chunk: ~60 kB pickled at 4 joints with p, v, a
CHUNK_BYTES = 128 * 1024  # a chunk's points pickled, at most: half of wire.MAX_MESSAGE (names besides)
_POINT_BYTES = 64  # one TrajectoryPoint pickled, without its values, at most
_VALUE_BYTES = 3 * 9  # per joint and point: position, velocity, acceleration, 9 bytes each pickled


def chunk_points(joints: int) -> int:
    """Points per chunk of a trajectory of ``joints`` joints: :data:`CHUNK_POINTS`, fewer when
    that many points could pickle to more than :data:`CHUNK_BYTES` (468 at 8 joints, 73 at 64,
    the most a trajectory message may name), so a valid trajectory's chunk never goes over the
    boundary's byte limit (500 points at 20 joints did: ~290 kB)."""
    return max(1, min(CHUNK_POINTS, CHUNK_BYTES // (_POINT_BYTES + _VALUE_BYTES * max(joints, 1))))


AxisIntentName = Literal['enable', 'disable', 'quick_stop', 'halt', 'resume', 'fault_reset', 'set_mode',
                         'home', 'wait_target_reached']
StopName = Literal['quick_stop', 'halt', 'disable', 'trajectories']


@dataclass(frozen=True)
class Start:
    """The first message: which configuration to load (as the node loaded it) and the
    executor's and forwarding settings."""

    source: ConfigSource
    pvt_segment: float = 0.01
    pvt_lookahead: float = 0.05
    frames: bool = False


@dataclass(frozen=True)
class Request:
    id: int
    body: object


@dataclass(frozen=True)
class Stop:
    """A stop on the stop lane: end the joints' trajectories (``reason``, ``state``, ``smooth``
    as ``TrajectoryExecutor.stop``), then for ``quick_stop``/``halt``/``disable`` the axis intent.
    The answer maps each joint to '' (done) or the error text."""

    joints: tuple[str, ...]
    action: StopName
    reason: str = ''
    state: str = 'cancelled'
    smooth: bool = False
    timeout: float | None = None
    halt: bool = True  # halt: on (True) or released (False is 'resume', a request-lane intent)


@dataclass(frozen=True)
class AxisIntent:
    """One joint driver intent that may wait for the drive (request lane)."""

    joint: str
    action: AxisIntentName
    timeout: float | None = None
    mode: int | str | None = None  # set_mode


@dataclass(frozen=True)
class JointCommand:
    joint: str
    position: float | None = None
    velocity: float | None = None
    effort: float | None = None


@dataclass(frozen=True)
class DirectCommands:
    """Direct commands of one message, checked whole in the bus process, then applied (all or
    none); a refusal comes back as ``reports.CommandRefused`` naming ``topic``. Latest value
    wins: the node process sends at most one per topic and joint set per cycle."""

    topic: str
    commands: tuple[JointCommand, ...]


@dataclass(frozen=True)
class TrajectoryChunk:
    """Part ``chunk`` (0-based) of ``chunks`` of trajectory ``submission``; the bus process
    submits it once every chunk is in. The answer to the last chunk is the handle (a
    ``reports.HandleState``) or the refusal; earlier chunks are answered ``None``."""

    submission: int
    chunk: int
    chunks: int
    joints: tuple[str, ...]
    points: tuple[TrajectoryPoint, ...]
    start: float | None
    source: str


@dataclass(frozen=True)
class SdoRead:
    node_id: int
    index: int
    subindex: int
    data_type: int = 0


@dataclass(frozen=True)
class SdoWrite:
    node_id: int
    index: int
    subindex: int
    value: bool | int | float | str | bytes
    data_type: int = 0


@dataclass(frozen=True)
class Nmt:
    command: int
    node_id: int = 0


ParameterOp = Literal['read', 'write', 'save', 'stores', 'safety']


@dataclass(frozen=True)
class ParameterCall:
    """The family's parameter access of ``node_id`` (seen from axis ``slot`` when given)."""

    node_id: int
    op: ParameterOp
    name: str = ''
    value_text: str = ''
    drive_object: int = 0
    slot: int | None = None


QueryName = Literal['snapshot', 'desired', 'operational', 'events', 'feeders', 'stop_deceleration']


@dataclass(frozen=True)
class Query:
    """Answered from the bus process's state: ``snapshot`` (a BusSnapshot), ``desired``
    (each joint's desired JointSample at ``at``), ``operational`` (waits up to ``timeout``
    until the nodes named in ``joints`` are operational, all when empty), ``events`` (the
    recent BusEvents), ``stop_deceleration`` (each joint's, SI). The test query ``feeders``:
    each PVT joint's feeder (``reports.FeederState``)."""

    what: QueryName
    joints: tuple[str, ...] = ()
    at: float = 0.0
    timeout: float = 0.0


@dataclass(frozen=True)
class Settings:
    """Run-time settings: whether frames are forwarded (recording, ``~/can_frames``), the
    executor's PVT timing, and a timing capture of the bus to a file (``capture``: a path
    starts it, '' stops it and writes the file; :mod:`.capture`)."""

    frames: bool | None = None
    capture: str | None = None
    pvt_segment: float | None = None
    pvt_lookahead: float | None = None


TEST_HOOKS = 'DRIVE_BRIDGE_TEST_HOOKS'  # environment: the bus process honours InjectSetpoint when '1'


@dataclass(frozen=True)
class InjectSetpoint:
    """A test hook: from the next cycle the joint's set-point source returns this set-point, as a
    buggy source would, past every check above the cycle's own (``docs/development.md``).
    Refused unless the bus process runs with :data:`TEST_HOOKS` = 1 in its environment."""

    joint: str
    position: float | None = None
    velocity: float | None = None
    effort: float | None = None


@dataclass(frozen=True)
class Shutdown:
    """Stop motion (quick stop of enabled axes), release the bus, exit."""

    reason: str = 'node shutting down'
