"""What a drive family *is*, as records with CiA 301/402 defaults: how its nodes boot and are
watched, how their PDOs are set, which modes it takes and how it streams them, what its axes
are. A family sets the records whose defaults do not fit (``boot = BootTraits(...)``); the
configuration, the master and the CiA 402 driver read them and test no vendor name."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum

from drive_bridge.cia402.profile import FaultModel
from drive_bridge.model import PositionLoopConfig


class BootDetection(str, Enum):
    """How a node announces that it (re)booted."""

    BOOTUP_FRAME = 'bootup frame'  # CiA 301: 0x700 + id with one zero byte
    EMCY = 'emcy'  # an EMCY the family recognises (``is_bootup_emcy``)
    PROBE = 'probe'  # no announcement: an SDO read of 0x1000 answers once it is up


class PdoConfiguration(str, Enum):
    """How the master sets a node's PDOs at boot."""

    FREE_MAPPING = 'free mapping'  # write 0x1400../0x1600.. / 0x1800../0x1A00.. (CiA 301)
    SELECT_BY_NUMBER = 'select by number'  # the family's ``select_pdo`` picks a predefined PDO


@dataclass(frozen=True)
class BootTraits:
    """How a node boots, and how it behaves towards its master."""

    detection: BootDetection = BootDetection.BOOTUP_FRAME
    # the node knows NMT reset communication (0x82); False: a node's `reset_communication`
    # defaults to false, and the master finds it by its boot-up announcement or an SDO probe
    nmt_reset_communication: bool = True
    has_heartbeat: bool = True  # False: the node must be guarded (config guard_time_ms)
    # the drive keeps its last references when its master goes silent (no heartbeat consumer,
    # no RPDO timeout, no action on a guarding loss): the bridge must stop it itself
    runs_on_without_master: bool = False


@dataclass(frozen=True)
class PdoTraits:
    """How the master sets the node's PDOs."""

    configuration: PdoConfiguration = PdoConfiguration.FREE_MAPPING
    # communication-parameter sub-indices the node has (CiA 301: 1 COB-ID, 2 type, 3 inhibit,
    # 5 event timer, 6 SYNC start); the master writes only these
    comm_subindices: frozenset[int] = frozenset({1, 2, 3, 5, 6})


@dataclass(frozen=True)
class ModeTraits:
    """Which modes the family's axes take, and how trajectories reach them."""

    accepted: frozenset[int] | None = None  # the modes it takes, when 0x6502 says otherwise
    # default of the axis keys mode / position_mode / velocity_mode / effort_mode, where they
    # differ from csp / csp / csv / cst
    defaults: Mapping[str, str] = field(default_factory=dict)
    # an axis that names no mode gets the best streaming mode the drive's 0x6502 has (at boot)
    from_drive: bool = False
    pvt_submode: int | None = None  # 0x60C0 code of the family's PVT interpolation, if any
    default_interpolation: str = 'linear'  # 'linear' or 'pvt', for axes that do not say
    interpolation_fault_codes: frozenset[int] = frozenset()  # EMCY: buffer underflow/overflow
    # the position loop of axes that give no `position_loop` (e.g. a velocity-only drive line)
    default_position_loop: PositionLoopConfig = PositionLoopConfig()


@dataclass(frozen=True)
class AxisTraits:
    """What the family's axes are and how their values are scaled."""

    has_cia402: bool = True  # axes are CiA 402 axes (else the family brings its driver)
    max_count: int = 1  # axes one node drives with the family's default PDO map
    uses_axis_scaling: bool = True  # False: the driver scales from the axis' `drive` settings
    fault_model: FaultModel = FaultModel()  # a Fault state, the controlword's reset bit


# the flat class attributes a family set before these records: name -> what to set instead. A
# family that still sets one would be read no more, so registering it fails naming the record.
FLAT_TRAITS: dict[str, str] = {
    'boot_detection': 'boot = BootTraits(detection=...)',
    'nmt_reset_communication': 'boot = BootTraits(nmt_reset_communication=...)',
    'has_heartbeat': 'boot = BootTraits(has_heartbeat=...)',
    'runs_on_without_master': 'boot = BootTraits(runs_on_without_master=...)',
    'pdo_configuration': 'pdo = PdoTraits(configuration=...)',
    'pdo_comm_subindices': 'pdo = PdoTraits(comm_subindices=...)',
    'accepted_modes': 'modes = ModeTraits(accepted=...)',
    'default_modes': 'modes = ModeTraits(defaults=...)',
    'modes_from_drive': 'modes = ModeTraits(from_drive=...)',
    'pvt_submode': 'modes = ModeTraits(pvt_submode=...)',
    'default_interpolation': 'modes = ModeTraits(default_interpolation=...)',
    'interpolation_fault_codes': 'modes = ModeTraits(interpolation_fault_codes=...)',
    'default_position_loop': 'modes = ModeTraits(default_position_loop=...)',
    'has_cia402': 'axes = AxisTraits(has_cia402=...)',
    'max_axes': 'axes = AxisTraits(max_count=...)',
    'uses_axis_scaling': 'axes = AxisTraits(uses_axis_scaling=...)',
    'fault_model': 'axes = AxisTraits(fault_model=...)',
}
