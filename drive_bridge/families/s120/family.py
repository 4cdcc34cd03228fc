"""The ``sinamics_s120`` family: SINAMICS S120 drive units with the CBC10 CANopen board
(shared/drives/sinamics-s120-cbc10.md, from the manual "SINAMICS S120 Interfaccia CANopen"
04/2014, firmware 4.7).

One node (the Control Unit) carries up to 8 drive objects, one per axis slot: objects at
+0x800 (CiA 402), +0x40 (PDO parameters), PDO numbers +64 per slot; p8743 says which DO sits in
which slot. What the bridge knows beyond the EDS (the config names the vendor's EDS with
``dcf``; the family ships none):

- EDS: the modular V4.8 EDS is expanded for the configured slots, the flat one is taken as it
  is and copied to further slots (:mod:`~drive_bridge.families.s120.eds`);
- PDOs: a default map per slot with COB-IDs for every slot, the drive's PDO limits, remapping
  by the entries with an abort on the read-only count sub0 accepted (canopen's ``PdoMap.save``
  does exactly that: abort 0x06010002 on sub0 is taken, the entries are written one by one)
  (:mod:`~drive_bridge.families.s120.pdos`);
- boot: NMT pre-operational before the first SDO (p8684), p8743, the units, p8848 against the
  cycle, p8641, the COB-IDs freed (:mod:`~drive_bridge.families.s120.boot`);
- supervision: life guarding only (the drive produces a heartbeat but consumes none, so only
  guarding lets it notice a lost bridge): the config must give ``guard_time_ms``; the core's
  guarding step writes 0x1017 = 0, 0x100C and 0x100D;
- modes: VL, PV and PT only (0x6060 always accepts a write and reads it back; 0x6061 tells);
  csp / ip / hm are refused before anything is sent; default pv, with the bridge's position
  loop over 0x60FF for position commands and trajectories (``default_position_loop``);
- position actual 0x6063 (no 0x6064); units read from the drive (:mod:`~.units`);
- EMCY: fault number (bytes 3-4) and DO (byte 5) to the joint by p8743 (:mod:`~.emcy`);
- faults: acknowledged by 0x1003:00 = 0 and the controlword edge (:mod:`~.driver`);
- parameters: p/r numbers of any DO through the window 0x2000+ and the selector p8630
  (:mod:`~.parameters`).
"""
from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from canopen import ObjectDictionary

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.axis import Axis
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.profile import AxisObjects
from drive_bridge.families.interface import DriveFamily, IdentityMatch, Liveness
from drive_bridge.families.parameters import ParameterPort
from drive_bridge.families.ports import BootStep, NodePort
from drive_bridge.families.registry import register_family
from drive_bridge.families.s120 import boot, eds, emcy, objects as s, pdos
from drive_bridge.families.s120.driver import S120Quirks
from drive_bridge.families.s120.options import parse_options
from drive_bridge.families.s120.parameters import SAFETY_PARAMETERS, S120Parameters, read_number, sdo_index
from drive_bridge.joint import JointDriver, NodeIo
from drive_bridge.model import AxisConfig, Identity, NodeConfig, PdoConfig, PositionLoopConfig, Timeouts

log = logging.getLogger('drive_bridge.families.s120')

# 1/s and rad (m): the loop corrects an error of 0.1 rad with 1 rad/s on top of the feed-forward.
# Conservative for a real drive: an 8 ms cycle, the sampling time p8848 and the next-SYNC latch make
# ~24 ms of delay (gain x delay = 0.24). Against the simulated S120 at 8 ms: 1 rad in 1.5 s (quintic)
# with ~2 mrad max error in the loop's own frame (test_s120_family.py).
DEFAULT_LOOP = PositionLoopConfig(gain=10.0, following_error=0.2)
PROFILE_OBJECTS = (s.PROFILE_OBJECTS[0], s.PROFILE_OBJECTS[1] + s.PROFILE_OFFSET * (s.MAX_DRIVE_OBJECTS - 1))


@register_family
class SinamicsS120(DriveFamily):
    """SINAMICS S120 + CBC10: one node, up to 8 drive objects (axis slots)."""

    name = 'sinamics_s120'
    description = 'Siemens SINAMICS S120 with CBC10 (CANopen; VL/PV/PT, the bridge closes the position loop)'
    vendor_safety_objects = {sdo_index(number): text for number, text in SAFETY_PARAMETERS.items()}
    default_eds = None  # the vendor's EDS, named by the config's dcf
    has_cia402 = True
    max_axes = s.MAX_DRIVE_OBJECTS
    emcy_texts = emcy.EMCY_CODE_TEXTS
    accepted_modes = frozenset({Mode.VELOCITY, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE})
    default_modes = {'mode': 'pv', 'position_mode': 'pv', 'velocity_mode': 'pv', 'effort_mode': 'pt'}
    has_heartbeat = False  # as a consumer: life guarding is the drive's only way to notice a lost master
    uses_axis_scaling = False  # units are read from the drive; the axis' `drive` settings give the mechanics
    default_position_loop = DEFAULT_LOOP
    pdo_comm_subindices = frozenset({1, 2, 3, 5})  # RPDO 1-2; TPDO 1-5 with 4 a reserved compatibility entry

    def __init__(self) -> None:
        self._mappable: dict[int, bool] | None = None  # from the prepared EDS: index -> PDO-mappable
        self._drivers: dict[int, S120Quirks] = {}  # by slot (one family instance per node)
        self._slot_of_do: dict[int, int] = {}  # DO number -> slot (p8743, read at boot)
        self._do_of_slot: dict[int, int] = {}
        self._cycle_period: float | None = None

    # -- configuration ------------------------------------------------------------------------------
    def eds_for(self, axis_count: int) -> Path | None:
        return None

    def identity_match(self, identity: Identity, device_name: str) -> IdentityMatch:
        """No EDS is shipped: the modular node's device type (several CiA 402 logical devices)."""
        if identity.device_type == (eds.MULTI_DEVICE << 16) | eds.DRIVE_PROFILE:
            return IdentityMatch.DEVICE_TYPE
        return IdentityMatch.NONE

    def prepare_object_dictionary(self, od: ObjectDictionary, slots: Sequence[int]) -> Sequence[str]:
        problems = eds.prepare(od, slots)
        self._mappable = {}
        for index in od.indices:
            if PROFILE_OBJECTS[0] <= index <= PROFILE_OBJECTS[1]:
                entry = od[index]
                self._mappable[index] = bool(getattr(entry, 'pdo_mappable', False))
        return problems

    def _is_mappable(self, index: int) -> bool:
        return True if self._mappable is None else self._mappable.get(index, False)

    def default_pdos(self, node_id: int, axes: Sequence[AxisConfig],
                     synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        return pdos.default_pdos(node_id, axes, synchronous, self._is_mappable)

    def check_pdos(self, rpdos: Sequence[PdoConfig], tpdos: Sequence[PdoConfig], slots: Sequence[int]) -> list[str]:
        """The drive's PDO limits this node's PDOs break (for the loader; see the report)."""
        return pdos.check_pdos(rpdos, tpdos, slots)

    def parse_axis_options(self, options: Mapping[str, Any]) -> tuple[Mapping[str, Any], Sequence[tuple[str, str]]]:
        return parse_options(options)

    def liveness(self, config: NodeConfig) -> Liveness:
        """Life guarding: the config requires guard_time_ms (``has_heartbeat = False``)."""
        return Liveness.GUARDING if config.guarding else Liveness.NONE

    # -- axes ---------------------------------------------------------------------------------------
    def axis_objects(self, slot: int) -> AxisObjects:
        """0x6063 position actual (r0482; no 0x6064), 0x606C / 0x6077 actual, 0x60FF / 0x6071
        targets, each +0x800 per slot; the target position 0x607A does not exist (never sent)."""
        return replace(AxisObjects.cia402(slot), position_actual=(s.profile_index(s.POSITION_ACTUAL, slot), 0))

    # -- the joint driver ----------------------------------------------------------------------------
    def create_joint_driver(self, node: NodeIo, axis: AxisConfig, timeouts: Timeouts,
                            cycle_period: float) -> JointDriver:
        driver = S120Quirks(axis)
        self._drivers[axis.slot] = driver
        self._cycle_period = cycle_period
        return Axis(node, axis, timeouts, cycle_period, profile=self, quirks=driver)

    # -- boot -----------------------------------------------------------------------------------------
    def boot_steps_early(self, node: NodePort) -> Sequence[BootStep]:
        return (('NMT enter pre-operational (p8684 may have left it stopped)', boot.enter_pre_operational),)

    def boot_steps_before(self, node: NodePort) -> Sequence[BootStep]:
        return (('drive objects p8743', self._read_drive_objects),
                ('units p0408/p0418/r0333', self._read_units),
                ('CAN sampling time p8848', self._check_sampling_time),
                ('fault reaction p8641', self._check_fault_reaction),
                ('PDO limits', boot.check_limits),
                ('free the PDO COB-IDs', boot.free_cob_ids))

    def _read_drive_objects(self, node: NodePort) -> None:
        found = boot.read_drive_objects(node)
        self._do_of_slot = found
        self._slot_of_do = {do: slot for slot, do in found.items()}

    def _read_units(self, node: NodePort) -> None:
        for slot, do in sorted(self._do_of_slot.items()):
            driver = self._drivers.get(slot)
            units = boot.read_units(node, do, slot, driver.options.encoder if driver is not None else None)
            if driver is not None:
                driver.apply_units(units, do)
            log.info('node %d (%s) slot %d = DO %d: %s', node.node_id, node.name, slot, do, units.describe())

    def _check_sampling_time(self, node: NodePort) -> None:
        boot.check_sampling_time(node, self._cycle_period)

    def _check_fault_reaction(self, node: NodePort) -> None:
        boot.warn_fault_reaction(node, self._do_of_slot)

    # -- EMCY and parameters ------------------------------------------------------------------------
    def decode_emcy(self, node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent:
        return emcy.decode(node_id, node_name, data, timestamp, self._slot_of_do)

    def drive_object_of(self, slot: int) -> int | None:
        """The DO number of an axis slot (p8743, known once the node booted)."""
        return self._do_of_slot.get(slot)

    def stores_parameters(self, config: NodeConfig, index: int, subindex: int) -> bool:
        """Also the parameter window of p0970/p0971/p0976/p0977 (reset, save, restore, save all)."""
        return (super().stores_parameters(config, index, subindex)
                or index in {s.PARAMETER_BASE + number for number in s.STORE_NUMBERS})

    def parameters(self, port: ParameterPort) -> S120Parameters:
        """p/r parameters of any drive object (0x2000 + number, selector p8630)."""
        config: NodeConfig | None = getattr(port, 'config', None)

        def drive_object_of(slot: int | None) -> int:
            if slot is None:
                if config is None or not config.axes:
                    raise LookupError('the node has no configured axis')
                slot = config.axes[0].slot
            known = self._do_of_slot.get(slot)
            if known is not None:
                return known
            return int(read_number(port, s.CU_DO, s.P_DO_OF_SLOT, slot))
        return S120Parameters(port, drive_object_of)
