"""The per-node part of a drive family: what the bridge learns of one node at run time, and
the hooks that need it.

:class:`~drive_bridge.families.interface.DriveFamily` describes a line of drives and holds no
state: one object per family serves the configuration, a scan and every node of the bus.
Whatever a boot reads of one node (its drive objects, units, the cycle its drivers run at) and
the joint drivers made for its axes live here, in the :class:`FamilyNode` the family makes once
per configured node (``DriveFamily.node``). Every hook defaults to plain CiA 301/402:

| question                              | hook                                                |
|---------------------------------------|-----------------------------------------------------|
| extra boot steps                      | ``boot_steps_early``, ``boot_steps_before``,        |
|                                       | ``boot_steps_after``                                |
| which joint driver?                   | ``create_joint_driver``                             |
| where does a CiA 402 axis differ?     | ``axis_quirks`` (plain ``AxisQuirks``)              |
| what does this node's EMCY mean?      | ``decode_emcy`` (the family's, by default)          |
| vendor parameters?                    | ``parameters``                                      |
| a drive that runs on without master   | ``stop_run_on``                                     |
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.axis import Axis
from drive_bridge.cia402.profile import Cia402Profile
from drive_bridge.cia402.quirks import AxisQuirks
from drive_bridge.families.ports import BootStep, NodePort
from drive_bridge.joint import JointDriver, NodeIo
from drive_bridge.model import AxisConfig, NodeConfig, Timeouts

if TYPE_CHECKING:
    from drive_bridge.families.parameters import ParameterAccess, ParameterPort


class NodeFamily(Cia402Profile, Protocol):
    """What a node's part asks of its family (a ``DriveFamily``): the CiA 402 profile its axes
    are built with, and the family's EMCY decoding."""

    def decode_emcy(self, node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent: ...


class FamilyNode:
    """One configured node of a family at run time (the master's, or a recording's decoder).

    A family that learns something per node subclasses this and returns it from
    ``DriveFamily.node``; the subclass keeps what it learns on itself, never on the family.
    """

    def __init__(self, family: NodeFamily, config: NodeConfig) -> None:
        self.family = family
        self.config = config
        self.cycle_period: float | None = None  # s, the cycle its joint drivers run at, once made

    @property
    def node_id(self) -> int:
        return self.config.node_id

    @property
    def name(self) -> str:
        return self.config.name

    # -- boot --------------------------------------------------------------------------------
    def boot_steps_early(self, node: NodePort) -> Sequence[BootStep]:
        """Steps right after boot-up, before the first SDO (identity): e.g. an NMT command a
        node needs before it answers SDO at all."""
        return ()

    def boot_steps_before(self, node: NodePort) -> Sequence[BootStep]:
        """Steps after boot-up and identity, before the configured boot SDOs."""
        return ()

    def boot_steps_after(self, node: NodePort) -> Sequence[BootStep]:
        """Steps after PDOs and supervision are configured, before NMT start."""
        return ()

    # -- axes ----------------------------------------------------------------------------------
    def create_joint_driver(self, node: NodeIo, axis: AxisConfig, timeouts: Timeouts,
                            cycle_period: float) -> JointDriver:
        """The driver of one axis: the CiA 402 axis with this node's :meth:`axis_quirks`, unless
        the family brings its own driver (a drive without CiA 402)."""
        self.cycle_period = cycle_period
        return Axis(node, axis, timeouts, cycle_period, profile=self.family, quirks=self.axis_quirks(axis))

    def axis_quirks(self, axis: AxisConfig) -> AxisQuirks:
        """Where this drive's axis differs from CiA 402 (plain by default); a family whose boot
        applies what it reads (units) to the quirks keeps them here by slot."""
        return AxisQuirks()

    # -- EMCY ----------------------------------------------------------------------------------
    def decode_emcy(self, data: bytes, timestamp: float) -> EmcyEvent:
        """This node's EMCY: the family's decoding, by default (a family whose decoding needs
        what the boot learned, e.g. which axis a drive object is, overrides it)."""
        return self.family.decode_emcy(self.node_id, self.name, data, timestamp)

    # -- vendor parameters ---------------------------------------------------------------------
    def parameters(self, port: ParameterPort) -> ParameterAccess | None:
        """Access to the drive's own parameters by their vendor names (None: not offered)."""
        return None

    # -- a drive that runs on by itself ----------------------------------------------------------
    def stop_run_on(self, by_sdo: bool) -> bool:
        """A drive that runs on by itself (``DriveFamily.boot.runs_on_without_master``) whose master
        liveness is lost while it still sends: put its stop into this cycle's process data
        (``by_sdo``: write it by SDO too, supervisor thread); True once the drive reports it is
        at rest."""
        return True
