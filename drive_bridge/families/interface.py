"""The drive family interface: the one boundary the core talks to.

Like python-can's ``BusABC`` for CAN interfaces, :class:`DriveFamily` stands between the core
and everything a drive line does differently. Every hook has a default that is plain CiA
301/402; a family overrides only what its manual says differs. The master, the CiA 402 driver,
streaming and the ROS layer ask the family and never test a vendor name.

| question                         | hook or trait (module ``traits``)                      |
|----------------------------------|--------------------------------------------------------|
| how does boot-up show?           | ``boot`` (detection, NMT reset communication),         |
|                                  | ``is_bootup_emcy``, ``bootup_emcy_is_ambiguous``       |
| how is the node supervised?      | ``liveness``, ``boot`` (has_heartbeat)                 |
| how are PDOs configured?         | ``pdo`` (configuration, comm_subindices), ``select_pdo``, ``sent_on_write`` |
| which objects carry the values?  | ``axis_objects``                                       |
| what does an EMCY mean?          | ``decode_emcy``, ``is_stream_fault``                   |
| which modes, streamed how?       | ``modes`` (``accepted``, ``pvt_submode``),             |
|                                  | ``streaming_strategy``, ``pvt_record``                 |
| what is a fault, how is it reset?| ``axes`` (``fault_model``)                             |
| which writes store or restore?   | ``stores_parameters`` (and ``ParameterAccess.stores``) |
| which writes decide the reaction | ``safety_object`` (and ``ParameterAccess.safety``),    |
| to a lost master or the link?    | ``boot`` (runs_on_without_master)                      |
| defaults for the config          | ``eds_for``, ``default_pdos``, ``default_pdos_for_eds``, ``plan_pdos``, |
|                                  | ``axes`` (max_count)                                   |
| what the EDS and PDOs cannot say | ``prepare_object_dictionary``, ``check_pdos``          |
| the axis' own ``drive`` settings | ``parse_axis_options``                                 |
| is this scanned node one of mine?| ``identity_match``, ``vendor_name``                    |
| one node at run time             | ``node``: its :class:`~drive_bridge.families.node.FamilyNode` |

The family holds no state: :func:`~drive_bridge.families.get_family` gives one object per family
for the configuration, a scan and every node. What is learned of one node (boot steps, the joint
drivers, vendor parameters, the stop of a drive that runs on) is the per-node part's,
:class:`~drive_bridge.families.node.FamilyNode`, made once per node by ``node``.
"""
from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum, IntEnum
from pathlib import Path
from typing import Any, ClassVar

import canopen
from canopen import ObjectDictionary

from drive_bridge.cia301.emcy import EmcyEvent, decode_emcy
from drive_bridge.cia301.vendors import vendor_name as cia301_vendor_name
from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.profile import AxisObjects, PvtRecord, standard_strategy
from drive_bridge.families.node import FamilyNode
from drive_bridge.families.traits import (
    AxisTraits,
    BootTraits,
    ModeTraits,
    PdoTraits,
)
from drive_bridge.joint.strategy import StreamStrategy
from drive_bridge.model import AxisConfig, Identity, NodeConfig, PdoConfig

STORE_PARAMETERS = 0x1010  # CiA 301: store parameters ("save")
# objects that decide how a node reacts to the loss of its master or that change its link
# (CiA 301 / 402): closed to clients unless the bus config's access.safety_objects names them
SAFETY_OBJECTS: Mapping[int, str] = {
    0x6007: 'the abort connection option code (what the drive does when its master is lost)',
    0x1005: 'the SYNC COB-ID',
    0x100C: 'the guard time (node guarding)',
    0x100D: 'the life time factor (node guarding)',
    0x1016: 'the consumer heartbeat time (the drive watching its master)',
    0x1017: 'the producer heartbeat time (the master watching the drive)',
    0x1029: 'the error behaviour (what a communication error does)',
}
RESTORE_DEFAULT_PARAMETERS = 0x1011  # CiA 301: restore default parameters ("load")


class Liveness(str, Enum):
    """How the master watches a node; never both on one node."""

    HEARTBEAT = 'heartbeat'
    GUARDING = 'node guarding'
    NONE = 'none'


@dataclass(frozen=True)
class PdoPlan:
    """A node's default process data, fitted to its EDS: the PDOs, its axes as the map leaves
    them (e.g. velocity estimated, the modes the map can stream), the inputs read by SDO
    instead, and one line saying what was mapped and why."""

    rpdos: tuple[PdoConfig, ...]
    tpdos: tuple[PdoConfig, ...]
    axes: tuple[AxisConfig, ...]
    polled: tuple[tuple[int, int], ...] = ()
    summary: str = ''


class IdentityMatch(IntEnum):
    """How surely a node found on a bus (0x1000, 0x1008, 0x1018) is one of a family's drives."""

    NONE = 0
    ANY = 1  # the family takes any CANopen node (a fallback)
    PROFILE = 2  # the device profile (0x1000, low word) fits
    DEVICE_TYPE = 3  # the whole device type fits
    VENDOR = 4  # the vendor id fits
    PRODUCT = 5  # the vendor id and product code (or the device name) fit


@dataclass(frozen=True)
class EdsIdentity:
    """What a shipped EDS says of its device: [DeviceInfo] and the defaults of 0x1000/0x1008."""

    vendor_id: int
    vendor_name: str
    product_code: int
    device_type: int
    device_name: str


def _default(od: ObjectDictionary, index: int) -> Any:
    try:
        return od[index].default  # type: ignore[union-attr]
    except (KeyError, AttributeError):
        return None


@functools.cache
def eds_identity(path: Path) -> EdsIdentity:
    """The identity a shipped EDS describes (read once)."""
    od = canopen.import_od(str(path))
    info = od.device_information
    return EdsIdentity(int(info.vendor_number or 0), str(info.vendor_name or ''), int(info.product_number or 0),
                       int(_default(od, 0x1000) or 0), str(_default(od, 0x1008) or ''))


def match_eds_identity(eds: EdsIdentity, identity: Identity, device_name: str) -> IdentityMatch:
    """A node's identity against an EDS: a vendor id that differs rules the EDS out; vendor
    id 0 (unassigned) in the EDS matches only together with its product code."""
    if eds.vendor_id and identity.vendor_id is not None and identity.vendor_id != eds.vendor_id:
        return IdentityMatch.NONE
    if eds.device_name and device_name == eds.device_name:
        return IdentityMatch.PRODUCT
    if eds.product_code and (identity.vendor_id, identity.product_code) == (eds.vendor_id, eds.product_code):
        return IdentityMatch.PRODUCT
    if eds.vendor_id and identity.vendor_id == eds.vendor_id:
        return IdentityMatch.VENDOR
    if eds.device_type and identity.device_type == eds.device_type:
        return IdentityMatch.DEVICE_TYPE
    if eds.device_type and identity.device_type is not None and \
            identity.device_type & 0xFFFF == eds.device_type & 0xFFFF:
        return IdentityMatch.PROFILE
    return IdentityMatch.NONE


class DriveFamily:
    """What the bridge knows about one line of drives beyond their EDS.

    Subclasses set the class attributes and override the hooks that differ; registered with
    :func:`~drive_bridge.families.register_family` or the ``drive_bridge.families`` entry point.
    """

    name: ClassVar[str] = ''
    description: ClassVar[str] = ''
    default_eds: ClassVar[Path | None] = None  # shipped EDS used when the config names none
    emcy_texts: ClassVar[Mapping[int, str]] = {}  # family-specific EMCY code texts
    # vendor objects that decide the reaction to a lost master or change the link: index -> what
    vendor_safety_objects: ClassVar[Mapping[int, str]] = {}
    # the traits (module traits): set the records whose CiA 301/402 defaults do not fit
    boot: ClassVar[BootTraits] = BootTraits()
    pdo: ClassVar[PdoTraits] = PdoTraits()
    modes: ClassVar[ModeTraits] = ModeTraits()
    axes: ClassVar[AxisTraits] = AxisTraits()

    def node(self, config: NodeConfig) -> FamilyNode:
        """The per-node part of one configured node (made once per node, at run time); plain
        CiA 301/402 by default. A family that learns something per node returns its own."""
        return FamilyNode(self, config)

    # -- configuration defaults ------------------------------------------------------------
    def eds_for(self, axis_count: int) -> Path | None:
        """The shipped EDS for a node with ``axis_count`` axes (None: the config must name one)."""
        return self.default_eds

    def default_pdos(self, node_id: int, axes: Sequence[AxisConfig],
                     synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        """(RPDOs, TPDOs) used when the config gives no mapping."""
        return (), ()

    def default_pdos_for_eds(self, node_id: int, axes: Sequence[AxisConfig], synchronous: bool,
                             od: ObjectDictionary) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        """The family's fixed map as the node's loaded (and prepared) EDS ``od`` allows it, e.g.
        without the objects it lacks or will not map; by default ``default_pdos``."""
        return self.default_pdos(node_id, axes, synchronous)

    def plan_pdos(self, node_id: int, axes: Sequence[AxisConfig], synchronous: bool,
                  od: ObjectDictionary) -> PdoPlan:
        """The default process data of a node whose config gives no mapping, for its EDS
        ``od``; by default the family's fixed map (``default_pdos_for_eds``)."""
        rpdos, tpdos = self.default_pdos_for_eds(node_id, axes, synchronous, od)
        return PdoPlan(rpdos, tpdos, tuple(axes))

    def prepare_object_dictionary(self, od: ObjectDictionary, slots: Sequence[int]) -> Sequence[str]:
        """Adapt the loaded EDS to the node's configured axis slots before it is checked (e.g.
        a modular EDS that describes one drive object: add the objects of the others).
        Returns problems to report at the node's EDS (none by default)."""
        return ()

    def check_pdos(self, rpdos: Sequence[PdoConfig], tpdos: Sequence[PdoConfig],
                   slots: Sequence[int]) -> Sequence[str]:
        """The node's resolved PDOs (explicit or the family's default) against the drive's own PDO
        rules that its EDS cannot say (e.g. how many valid PDOs one device receives); ``slots``
        the node's axis slots. Returns problems to report at the node (none by default)."""
        return ()

    def parse_axis_options(self, options: Mapping[str, Any]) -> tuple[Mapping[str, Any], Sequence[tuple[str, str]]]:
        """Validate an axis' ``drive`` settings (the family's own keys; ``{}`` when the axis
        gives none): (the values the joint driver gets, [(key, error message)]). By default a
        family takes no such settings."""
        return {}, [(key, f"family '{self.name}' takes no drive settings") for key in options]

    # -- scan ----------------------------------------------------------------------------------
    def _shipped_identities(self) -> list[EdsIdentity]:
        paths = {p for p in (self.eds_for(n) for n in range(1, max(self.axes.max_count, 1) + 1)) if p is not None}
        return [eds_identity(p) for p in sorted(paths)]

    def identity_match(self, identity: Identity, device_name: str) -> IdentityMatch:
        """How surely a node that reports ``identity`` (0x1000, 0x1018; None where it did not
        answer) and ``device_name`` (0x1008) is one of this family's drives. By default: its
        shipped EDS files' [DeviceInfo] and defaults of 0x1000 / 0x1008."""
        return max((match_eds_identity(e, identity, device_name) for e in self._shipped_identities()),
                   default=IdentityMatch.NONE)

    def vendor_name(self, vendor_id: int) -> str | None:
        """The vendor of ``vendor_id`` (0x1018:1): from the family's shipped EDS files, else
        from the excerpt of CiA's register (drive_bridge.cia301.vendors)."""
        return next((e.vendor_name for e in self._shipped_identities()
                     if e.vendor_id == vendor_id != 0 and e.vendor_name), None) or cia301_vendor_name(vendor_id)

    # -- boot --------------------------------------------------------------------------------
    def is_bootup_emcy(self, data: bytes) -> bool:
        """With ``boot.detection`` EMCY: this EMCY payload is the node's boot-up announcement."""
        return False

    def bootup_emcy_is_ambiguous(self, data: bytes) -> bool:
        """With ``boot.detection`` EMCY: this boot-up payload can also be an ordinary EMCY (e.g.
        eight zero bytes, which also read as "no error"). From a node the master has running,
        such a frame counts as a reboot only once the node's next reported NMT state (guarding
        reply or heartbeat) is not operational."""
        return False

    def liveness(self, config: NodeConfig) -> Liveness:
        """How this node is supervised: heartbeat when it produces one, else node guarding
        when a guard time is configured, else not at all."""
        if config.heartbeat_producer_ms:
            return Liveness.HEARTBEAT
        if getattr(config, 'guard_time_ms', 0):
            return Liveness.GUARDING
        return Liveness.NONE

    # -- PDOs --------------------------------------------------------------------------------
    def select_pdo(self, kind: str, config: PdoConfig) -> Sequence[tuple[int, int, int]] | None:
        """With ``pdo.configuration`` SELECT_BY_NUMBER: the SDO writes (index, subindex, value)
        choosing the predefined PDO that ``config`` describes (kind 'RPDO' or 'TPDO'); None
        maps this PDO freely instead (a drive's free PDOs)."""
        raise NotImplementedError(f'family {self.name!r} selects no predefined PDOs')

    def sent_on_write(self, index: int, subindex: int) -> bool:
        """An RPDO carrying this object goes out only in a cycle that wrote it, not every
        cycle: writing it pushes a point into the drive's buffer (CiA 402: 0x60C1 of any axis)."""
        return index >= 0x6000 and (index - obj.INTERPOLATION_DATA_RECORD) % obj.AXIS_OFFSET == 0

    # -- axes ----------------------------------------------------------------------------------
    def axis_objects(self, slot: int) -> AxisObjects:
        """Objects carrying an axis' actual and target values."""
        return AxisObjects.cia402(slot)

    def streaming_strategy(self, mode: int, ip_submode: int) -> StreamStrategy | None:
        """How trajectories are streamed in ``mode`` (None: the mode takes no trajectory)."""
        return standard_strategy(mode, ip_submode, self.modes.pvt_submode)

    def pvt_record(self, slot: int) -> PvtRecord | None:
        """Where PVT points go (None: the family has no PVT)."""
        return None

    # -- EMCY ----------------------------------------------------------------------------------
    def decode_emcy(self, node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent:
        """Code, register and manufacturer bytes -> text, axis slot, severity, reset."""
        return decode_emcy(node_id, node_name, data, timestamp, self.emcy_texts)

    def is_stream_fault(self, event: EmcyEvent) -> bool:
        """The EMCY reports an interpolation buffer underflow or overflow (aborts a stream)."""
        return event.code in self.modes.interpolation_fault_codes

    # -- access ----------------------------------------------------------------------------------
    def safety_object(self, config: NodeConfig | None, index: int, subindex: int) -> str | None:
        """What this object decides when it is one of those that set how the drive reacts to the
        loss of its master or that change its communication (node id, bit rate, SYNC, guarding,
        heartbeat), else None. The ROS layer refuses client writes of such objects unless the bus
        config's ``access.safety_objects`` names them. CiA 301/402 here (0x6007 of every axis);
        a family adds its vendor objects (``vendor_safety_objects``)."""
        base = index if index < 0x6000 else 0x6000 + (index - 0x6000) % obj.AXIS_OFFSET
        return SAFETY_OBJECTS.get(base) or self.vendor_safety_objects.get(index)

    def stores_parameters(self, config: NodeConfig, index: int, subindex: int) -> bool:
        """An SDO write of this object stores the node's parameters in non-volatile memory or
        restores them (CiA 301: 0x1010, 0x1011; a family adds its own save and restore commands).
        The ROS layer refuses such writes from clients unless the bus config allows them."""
        return index in (STORE_PARAMETERS, RESTORE_DEFAULT_PARAMETERS)
