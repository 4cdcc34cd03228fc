"""The typed bus configuration: what the loader produces and the core consumes.

All values are validated and in the units the core works in (seconds, SI, raw
CANopen codes); the YAML's units and spellings stay in the loader. Objects are frozen
so a config can be shared between threads without copying.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from canopen import ObjectDictionary

from drive_bridge.access_rules import AccessConfig

JointType = Literal['revolute', 'prismatic']
SdoScalar = int | float | str | bytes
UPDATE_PERIOD_WITHOUT_SYNC = 0.01  # s, the master's cycle when no SYNC runs on the bus


@dataclass(frozen=True)
class PdoEntry:
    """One mapped object of a PDO."""

    index: int
    subindex: int
    bits: int


@dataclass(frozen=True)
class PdoConfig:
    """One RPDO or TPDO: communication parameters and mapping.

    ``cob_id`` is resolved (never 'auto'): the predefined connection set for PDOs 1..4
    (TPDO n: 0x180 + 0x100 * (n-1) + node id; RPDO n: 0x200 + 0x100 * (n-1) + node id),
    explicit values otherwise.
    """

    number: int  # 1..512
    cob_id: int
    enabled: bool = True
    transmission: int = 1  # 0 acyclic sync, 1..240 every n-th SYNC, 254/255 event driven
    inhibit_time: int = 0  # x100 us (TPDO)
    event_timer: int = 0  # ms
    sync_start: int = 0  # TPDO
    mapping: tuple[PdoEntry, ...] = ()

    @property
    def bits(self) -> int:
        return sum(entry.bits for entry in self.mapping)


@dataclass(frozen=True)
class SdoWriteItem:
    """One SDO download done at boot, in order. ``where`` locates it in the config file."""

    index: int
    subindex: int
    value: SdoScalar
    where: str = ''


@dataclass(frozen=True)
class Identity:
    """Expected identity (0x1000 and 0x1018); None = not checked."""

    device_type: int | None = None
    vendor_id: int | None = None
    product_code: int | None = None
    revision_number: int | None = None
    serial_number: int | None = None


@dataclass(frozen=True)
class Timeouts:
    """Every wait of the master for one node, in seconds, with retry counts."""

    boot: float = 2.0  # boot-up message / heartbeat after reset
    boot_retries: int = 3  # whole boot attempts before the node is reported failed (then retried slowly)
    boot_retry_interval: float = 5.0  # between rounds of boot attempts of a failed node
    sdo: float = 0.3  # one SDO request
    sdo_retries: int = 2  # extra attempts after an SDO timeout (not after an abort)
    state_switch: float = 1.0  # one CiA 402 state transition
    mode_switch: float = 1.0  # 0x6061 echoing 0x6060
    homing: float = 30.0
    command_timeout: float = 0.5  # dead-man: cyclic command stream silent this long -> hold


@dataclass(frozen=True)
class AxisScaling:
    """Linear device <-> SI conversion: SI = device * factor (+ offset for position).

    Direction and gear ratio are folded into the factors. Position SI is rad (revolute)
    or m (prismatic); velocity SI per s; effort N*m or N.
    """

    position_factor: float = 1.0
    position_offset: float = 0.0
    velocity_factor: float = 1.0
    effort_factor: float = 1.0

    def position_to_si(self, counts: float) -> float:
        return counts * self.position_factor + self.position_offset

    def position_to_device(self, si: float) -> int:
        return round((si - self.position_offset) / self.position_factor)

    def velocity_to_si(self, value: float) -> float:
        return value * self.velocity_factor

    def velocity_to_device(self, si: float) -> int:
        return round(si / self.velocity_factor)

    def effort_to_si(self, value: float) -> float:
        return value * self.effort_factor

    def effort_to_device(self, si: float) -> int:
        return round(si / self.effort_factor)


@dataclass(frozen=True)
class AxisLimits:
    """Joint limits in SI; None = not limited by the bridge. ``todo``: the places of scaling or
    limit keys the configuration marks TODO (a starter config of ``drive-bridge scan``): until
    they are set the joint reports its state but takes no command and no trajectory."""

    min_position: float | None = None
    max_position: float | None = None
    max_velocity: float | None = None
    max_acceleration: float | None = None
    max_effort: float | None = None
    on_violation: str = 'halt'  # what holds the axis when a set-point breaks a limit: halt or quick_stop
    # where each limit came from, for the start-up line: 'config', or the drive object read at boot
    sources: Mapping[str, str] = field(default_factory=dict, compare=False)
    todo: tuple[str, ...] = ()


@dataclass(frozen=True)
class PositionLoopConfig:
    """The bridge's position loop for a joint streamed through velocity set-points."""

    gain: float = 0.0  # 1/s; 0 = no loop (velocity modes take velocity set-points as they are)
    following_error: float | None = None  # SI; beyond it the stream is aborted and the axis held

    @property
    def enabled(self) -> bool:
        return self.gain > 0


@dataclass(frozen=True)
class NodeLossConfig:
    """What the bus process does with an enabled axis when the node process is gone: quick
    stop, then at rest ``disable`` (after ``brake_delay`` s, so the holding brake has engaged)
    or ``hold`` (quick stop active: holding torque, for a vertical axis)."""

    action: Literal['disable', 'hold'] = 'disable'
    brake_delay: float = 0.2  # s


@dataclass(frozen=True)
class HomingConfig:
    """Homing parameters; None leaves the drive's own value (0x6098, 0x6099, 0x609A, 0x607C)."""

    method: int | None = None
    speed_search: float | None = None  # SI/s, 0x6099:1
    speed_zero: float | None = None  # SI/s, 0x6099:2
    acceleration: float | None = None  # SI/s^2, 0x609A
    offset: float | None = None  # SI, 0x607C


@dataclass(frozen=True)
class ModeChoice:
    """The axis' default mode is picked at boot from the drive's 0x6502 (the config names none):
    the first of ``candidates`` the drive supports."""

    # modes the bridge can stream with this axis' PDO map, best first; None: the map was not
    # derived (explicit PDOs), every streaming mode is a candidate; () streams none
    candidates: tuple[int, ...] | None = None
    inferred_support: int | None = None  # 0x6502 bits from the EDS's objects when 0x6502 is absent


@dataclass(frozen=True)
class AxisConfig:
    """One CiA 402 axis of a node, mapped to one joint."""

    joint: str
    slot: int = 0  # axis slot on the node: objects at index + 0x800 * slot
    joint_type: JointType = 'revolute'
    mode: int = 8  # default mode of operation (0x6060 code)
    position_mode: int = 8  # mode used for position commands
    velocity_mode: int = 9  # mode used for velocity commands
    effort_mode: int = 10  # mode used for effort commands
    ip_submode: int = 0  # 0x60C0 in interpolated position mode: 0 linear, the family's code for PVT
    scaling: AxisScaling = field(default_factory=AxisScaling)
    limits: AxisLimits = field(default_factory=AxisLimits)
    homing: HomingConfig = field(default_factory=HomingConfig)
    position_loop: PositionLoopConfig = field(default_factory=PositionLoopConfig)
    node_loss: NodeLossConfig = field(default_factory=NodeLossConfig)
    # the drive family's own per-axis settings (the axis key `drive`), as its
    # parse_axis_options validated them
    drive: Mapping[str, Any] = field(default_factory=dict)
    auto_mode: ModeChoice | None = None  # None: ``mode`` as configured
    estimated_velocity: bool = False  # 0x606C is not in a PDO: velocity is derived from position
    where: str = ''


@dataclass(frozen=True)
class NodeConfig:
    """One CANopen node (drive) on the bus."""

    name: str
    node_id: int
    family: str  # key of the drive family registry
    od: ObjectDictionary  # loaded from eds_path (or the family's shipped EDS)
    eds_path: Path | None = None
    identity: Identity = field(default_factory=Identity)
    boot_sdo: tuple[SdoWriteItem, ...] = ()
    rpdo: tuple[PdoConfig, ...] = ()  # resolved: explicit, or the family default
    tpdo: tuple[PdoConfig, ...] = ()
    heartbeat_producer_ms: int = 100  # written to the node's 0x1017
    heartbeat_consumer: bool = True  # node monitors the master's heartbeat (0x1016)
    guard_time_ms: int = 0  # node guarding (0x100C), instead of a heartbeat; 0 = not guarded
    life_time_factor: int = 0  # 0x100D; node life time = guard time * factor (0 when not guarded)
    reset_communication: bool = True  # NMT reset communication before configuring
    timeouts: Timeouts = field(default_factory=Timeouts)
    axes: tuple[AxisConfig, ...] = ()
    polled: tuple[tuple[int, int], ...] = ()  # inputs in no TPDO, read by SDO at a lower rate
    pdo_summary: str = ''  # what the derived default map carries and why (logged at start)
    where: str = ''

    def __hash__(self) -> int:  # the OD is not hashable; a node is identified by name and id
        return hash((self.name, self.node_id))

    @property
    def guarding(self) -> bool:
        """The master guards this node (CiA 301 node guarding) instead of consuming a heartbeat."""
        return self.guard_time_ms > 0


@dataclass(frozen=True)
class BusInterface:
    """The python-can bus: ``can.Bus(interface=..., channel=..., bitrate=..., **options)``."""

    interface: str = 'virtual'
    channel: str | int = 'drive_bridge'
    bitrate: int | None = 1_000_000
    options: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class MasterConfig:
    """The bridge's own CANopen behaviour."""

    node_id: int = 127
    sync_period: float = 0.004  # s; 0 = the bridge sends no SYNC
    sync_producer: Literal['bridge', 'external', 'kernel'] = 'bridge'  # kernel: SocketCAN BCM
    heartbeat_producer_ms: int = 100  # master heartbeat (0 = none)
    heartbeat_consumer: bool = True  # master monitors the nodes' heartbeats
    heartbeat_multiplier: float = 3.0  # consumer time = producer time * multiplier
    sync_window: float | None = None  # s, written to 0x1007 of every node that has it; None = not written
    realtime_priority: int | None = None  # SCHED_FIFO priority of the cycle thread; None = normal

    @property
    def sends_sync(self) -> bool:
        """SYNC runs on the bus every ``sync_period`` (``sync_producer`` says who sends it); without
        it the master updates on its own clock and synchronous PDOs are not used."""
        return self.sync_period > 0

    @property
    def cycle_period(self) -> float:
        """The master's update period: the SYNC period, else UPDATE_PERIOD_WITHOUT_SYNC."""
        return self.sync_period if self.sends_sync else UPDATE_PERIOD_WITHOUT_SYNC


@dataclass(frozen=True)
class SimulationConfig:
    """Simulated drives for every node (only on the ``virtual`` interface)."""

    enabled: bool = False
    options: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)  # node name -> sim options


@dataclass(frozen=True)
class RecordConfig:
    """Recording the bus into a rosbag2 MCAP bag (the node's ``record.*`` parameters start from here)."""

    path: str = 'bags'  # directory of the bags; each recording is a new bag <channel>_<UTC time> in it
    split_size_mb: float = 0.0  # rotate to a new split at this size (0 = no size limit)
    split_seconds: float = 0.0  # rotate to a new split after this long (0 = no time limit)
    start: bool = False  # start recording when the node starts (before the bus opens)


@dataclass(frozen=True)
class TrajectoryConfig:
    """How trajectories beyond the joints' limits are treated (the ``trajectory`` section)."""

    scale_to_limits: bool = False  # stretch the segments in time instead of refusing the trajectory


@dataclass(frozen=True)
class BusConfig:
    """One bus: interface, master, nodes and their axes."""

    bus: BusInterface = field(default_factory=BusInterface)
    master: MasterConfig = field(default_factory=MasterConfig)
    nodes: tuple[NodeConfig, ...] = ()
    simulation: SimulationConfig = field(default_factory=SimulationConfig)
    access: AccessConfig = field(default_factory=AccessConfig)
    record: RecordConfig = field(default_factory=RecordConfig)
    trajectory: TrajectoryConfig = field(default_factory=TrajectoryConfig)
    path: Path | None = None
    warnings: tuple[str, ...] = ()  # accepted but ignored keys (e.g. ros2_canopen ones), each located
    allow_overload: bool = False  # bus.allow_overload: run a configuration the bus cannot carry

    def node(self, name: str) -> NodeConfig:
        for node in self.nodes:
            if node.name == name:
                return node
        raise KeyError(f'no node named {name!r}')

    def node_by_id(self, node_id: int) -> NodeConfig:
        for node in self.nodes:
            if node.node_id == node_id:
                return node
        raise KeyError(f'no node with id {node_id}')

    @property
    def axes(self) -> tuple[tuple[NodeConfig, AxisConfig], ...]:
        return tuple((node, axis) for node in self.nodes for axis in node.axes)
