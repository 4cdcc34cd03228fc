"""The ``servostar`` family: Kollmorgen SERVOSTAR 400/600 servo amplifiers with their built-in
CANopen interface (shared/drives/servostar-400-600.md, from the manual "CANopen SERVOSTAR
400/600", edition 12/2009, firmware >= 6.57).

What the bridge knows beyond the EDS (drive_bridge/families/servostar/data/servostar.eds):

- boot-up: an EMCY on 0x80 + id with 0 bytes or 8 zero bytes (DRVCNFG), no 0x700 frame, no NMT
  reset communication (a node's ``reset_communication`` defaults to false): the master waits for
  that EMCY or, for a drive that is already running, finds it by an SDO probe. The 8-byte form
  reads like an "error free" EMCY, so from a running drive it counts as a reboot only once the
  next guarding reply shows it left OPERATIONAL; the 0-byte form is taken at once;
- supervision: node guarding only (no heartbeat: the config must give ``guard_time_ms``); the
  drive's life guarding runs only while its output stage is enabled, its timeout is warning n04
  with a quick stop and EMCY 0x8181 (category 2), acknowledged by controlword bit 11
  (``~/fault_reset``);
- PDOs: chosen by library number (0x2600-0x2603, 0x2A00-0x2A03) or free PDOs 37-40; the
  communication records have sub-indices 1-3 only (no event timer) (:mod:`~.pdos`);
- boot steps: free PDO selection, units and limits (PRBASE, VLIM, PEMAX, DEC), PTBASE against
  the SYNC period (:mod:`~.boot`);
- modes: pp, pv, hm and the manufacturer modes -1 (0xFF), -2 (0xFE), -3 (0xFD), -6 (0xFA,
  trajectory: the default, streamed one setpoint per SYNC); no vl, tq, ip (refused before
  anything is sent);
- faults: no Fault state, 0x1002 bit 31 and the EMCY category; bit 7 (restart) or bit 11
  (:mod:`~.driver`); EMCY texts with fault number and category (:mod:`~.emcy`);
- parameters: the ASCII parameters of the object channel 0x3500+ by name (:mod:`~.parameters`).

Known gaps: RPDO 33 (two drives' setpoints in one frame, 0x2721 picking the half) is refused by
the loader: the bridge sends one frame per node; effort commands are not offered (0xFD takes a
current in 1640 = rated units, no CiA 402 torque mode); ``~/home`` uses the CiA 402 homing objects
with the axis' velocity scaling, which is the 0x2070:02 unit, not 0x6099's; 0x60FF in pv is sent
in increments per 250 us (0x6094 = 0/0) without a check against a real drive.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.profile import AxisObjects, FaultModel, standard_strategy
from drive_bridge.families.interface import DriveFamily, Liveness
from drive_bridge.families.registry import register_family
from drive_bridge.families.servostar import emcy, objects as o, pdos
from drive_bridge.families.servostar.node import ServostarNode
from drive_bridge.families.servostar.options import parse_options
from drive_bridge.families.servostar.parameters import STORE_COMMANDS, TABLE
from drive_bridge.families.traits import (
    AxisTraits,
    BootDetection,
    BootTraits,
    ModeTraits,
    PdoConfiguration,
    PdoTraits,
)
from drive_bridge.joint.strategy import StreamStrategy
from drive_bridge.model import AxisConfig, NodeConfig, PdoConfig
from drive_bridge.resources import family_data

STORE_OBJECTS = frozenset(TABLE[name].index for name in STORE_COMMANDS)


@register_family
class Servostar(DriveFamily):
    """Kollmorgen SERVOSTAR 400/600, one axis per node."""

    name = 'servostar'
    description = 'Kollmorgen SERVOSTAR 400/600 (CANopen; trajectory mode 0xFA, node guarding)'
    vendor_safety_objects = {
        0x3505: 'ADDR, the CAN node address',
        0x3515: 'CBAUD, the CAN bit rate',
    }
    default_eds = family_data('servostar', 'servostar.eds')
    emcy_texts = emcy.EMCY_TEXTS
    modes = ModeTraits(
        accepted=frozenset({Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY, Mode.HOMING, o.MODE_POSITION,
                            o.MODE_SPEED_DIGITAL, o.MODE_CURRENT_DIGITAL, o.MODE_TRAJECTORY}),
        defaults={'mode': str(o.MODE_TRAJECTORY), 'position_mode': str(o.MODE_TRAJECTORY),
                  'velocity_mode': 'pv', 'effort_mode': str(o.MODE_CURRENT_DIGITAL)})
    boot = BootTraits(detection=BootDetection.EMCY, nmt_reset_communication=False, has_heartbeat=False)
    pdo = PdoTraits(configuration=PdoConfiguration.SELECT_BY_NUMBER, comm_subindices=o.COMM_SUBINDICES)
    # PRBASE etc. are read at boot; the axis' `drive` settings give the mechanics
    axes = AxisTraits(uses_axis_scaling=False, fault_model=FaultModel(fault_state=False, reset_bit=o.CW_RESET_FAULT))

    # -- configuration ------------------------------------------------------------------------------
    def eds_for(self, axis_count: int) -> Path | None:
        return self.default_eds

    def default_pdos(self, node_id: int, axes: Sequence[AxisConfig],
                     synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        return pdos.default_pdos(node_id, axes, synchronous)

    def check_pdos(self, rpdos: Sequence[PdoConfig], tpdos: Sequence[PdoConfig], slots: Sequence[int]) -> list[str]:
        return pdos.check_pdos(rpdos, tpdos)

    def parse_axis_options(self, options: Mapping[str, Any]) -> tuple[Mapping[str, Any], Sequence[tuple[str, str]]]:
        return parse_options(options)

    def liveness(self, config: NodeConfig) -> Liveness:
        """Node guarding: the config requires guard_time_ms (``boot.has_heartbeat`` false)."""
        return Liveness.GUARDING if config.guarding else Liveness.NONE

    # -- boot-up ------------------------------------------------------------------------------------
    def is_bootup_emcy(self, data: bytes) -> bool:
        return emcy.is_bootup(data)

    def bootup_emcy_is_ambiguous(self, data: bytes) -> bool:
        """8 zero bytes are also the "error free" EMCY; 0 bytes are only ever the boot-up."""
        return len(data) != 0

    # -- PDOs ---------------------------------------------------------------------------------------
    def select_pdo(self, kind: str, config: PdoConfig) -> Sequence[tuple[int, int, int]] | None:
        """A library PDO by its number; None for a free PDO (selected by a boot step, mapped by the master)."""
        return pdos.select_writes(kind, config)

    # -- axes ---------------------------------------------------------------------------------------
    def axis_objects(self, slot: int) -> AxisObjects:
        """Actual position 0x2070:03 and speed 0x2070:02, torque 0x6077; targets: the trajectory
        setpoint 0x2022:04 (0x607A in pp, by the driver), 0x60FF; no torque target."""
        return AxisObjects(position_actual=o.ACTUAL_POSITION, velocity_actual=o.ACTUAL_SPEED,
                           effort_actual=o.TORQUE_ACTUAL, target_position=o.TRAJECTORY_SETPOINT,
                           target_velocity=o.TARGET_VELOCITY, target_effort=(0x2060, 0))

    def streaming_strategy(self, mode: int, ip_submode: int) -> StreamStrategy | None:
        """Mode 0xFA: one absolute position setpoint per SYNC (cyclic, as CSP)."""
        if mode == o.MODE_TRAJECTORY:
            return StreamStrategy.CYCLIC
        return standard_strategy(mode, ip_submode, None)

    # -- EMCY and parameters ------------------------------------------------------------------------
    def decode_emcy(self, node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent:
        return emcy.decode(node_id, node_name, data, timestamp)

    def stores_parameters(self, config: NodeConfig, index: int, subindex: int) -> bool:
        """Also the object channel's SAVE, LOAD and RSTVAR."""
        return super().stores_parameters(config, index, subindex) or index in STORE_OBJECTS

    def node(self, config: NodeConfig) -> ServostarNode:
        """The drive at run time: its units, PTBASE against the SYNC period (:mod:`~.node`)."""
        return ServostarNode(self, config)
