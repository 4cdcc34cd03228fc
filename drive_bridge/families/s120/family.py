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
  loop over 0x60FF for position commands and trajectories (``modes.default_position_loop``);
- position actual 0x6063 (no 0x6064); units read from the drive (:mod:`~.units`);
- EMCY: fault number (bytes 3-4) and DO (byte 5) to the joint by p8743 (:mod:`~.emcy`);
- faults: acknowledged by 0x1003:00 = 0 and the controlword edge (:mod:`~.driver`);
- parameters: p/r numbers of any DO through the window 0x2000+ and the selector p8630
  (:mod:`~.parameters`).
"""
from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from canopen import ObjectDictionary

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.profile import AxisObjects
from drive_bridge.families.interface import DriveFamily, IdentityMatch, Liveness
from drive_bridge.families.registry import register_family
from drive_bridge.families.s120 import eds, emcy, objects as s, pdos
from drive_bridge.families.s120.node import S120Node
from drive_bridge.families.s120.options import parse_options
from drive_bridge.families.s120.parameters import SAFETY_PARAMETERS, sdo_index
from drive_bridge.families.traits import AxisTraits, BootTraits, ModeTraits, PdoTraits
from drive_bridge.model import AxisConfig, Identity, NodeConfig, PdoConfig, PositionLoopConfig

# 1/s and rad (m): the loop corrects an error of 0.1 rad with 1 rad/s on top of the feed-forward.
# Conservative for a real drive: an 8 ms cycle, the sampling time p8848 and the next-SYNC latch make
# ~24 ms of delay (gain x delay = 0.24). Against the simulated S120 at 8 ms: 1 rad in 1.5 s (quintic)
# with ~2 mrad max error in the loop's own frame (test_s120_family.py).
DEFAULT_LOOP = PositionLoopConfig(gain=10.0, following_error=0.2)
PROFILE_OBJECTS = (s.PROFILE_OBJECTS[0], s.PROFILE_OBJECTS[1] + s.PROFILE_OFFSET * (s.MAX_DRIVE_OBJECTS - 1))


def _is_mappable(od: ObjectDictionary, index: int) -> bool:
    """The (prepared) EDS has this profile object, PDO-mappable."""
    if not PROFILE_OBJECTS[0] <= index <= PROFILE_OBJECTS[1] or index not in od:
        return False
    return bool(getattr(od[index], 'pdo_mappable', False))


@register_family
class SinamicsS120(DriveFamily):
    """SINAMICS S120 + CBC10: one node, up to 8 drive objects (axis slots)."""

    name = 'sinamics_s120'
    description = 'Siemens SINAMICS S120 with CBC10 (CANopen; VL/PV/PT, the bridge closes the position loop)'
    vendor_safety_objects = {sdo_index(number): text for number, text in SAFETY_PARAMETERS.items()}
    default_eds = None  # the vendor's EDS, named by the config's dcf
    emcy_texts = emcy.EMCY_CODE_TEXTS
    modes = ModeTraits(accepted=frozenset({Mode.VELOCITY, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE}),
                       defaults={'mode': 'pv', 'position_mode': 'pv', 'velocity_mode': 'pv', 'effort_mode': 'pt'},
                       default_position_loop=DEFAULT_LOOP)
    # as a consumer: life guarding is the drive's only way to notice a lost master
    boot = BootTraits(has_heartbeat=False)
    # units are read from the drive; the axis' `drive` settings give the mechanics
    axes = AxisTraits(max_count=s.MAX_DRIVE_OBJECTS, uses_axis_scaling=False)
    pdo = PdoTraits(comm_subindices=frozenset({1, 2, 3, 5}))  # RPDO 1-2; TPDO 1-5 with 4 a reserved compatibility entry

    # -- configuration ------------------------------------------------------------------------------
    def eds_for(self, axis_count: int) -> Path | None:
        return None

    def identity_match(self, identity: Identity, device_name: str) -> IdentityMatch:
        """No EDS is shipped: the modular node's device type (several CiA 402 logical devices)."""
        if identity.device_type == (eds.MULTI_DEVICE << 16) | eds.DRIVE_PROFILE:
            return IdentityMatch.DEVICE_TYPE
        return IdentityMatch.NONE

    def prepare_object_dictionary(self, od: ObjectDictionary, slots: Sequence[int]) -> Sequence[str]:
        return eds.prepare(od, slots)

    def default_pdos(self, node_id: int, axes: Sequence[AxisConfig],
                     synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        return pdos.default_pdos(node_id, axes, synchronous)

    def default_pdos_for_eds(self, node_id: int, axes: Sequence[AxisConfig], synchronous: bool,
                             od: ObjectDictionary) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        """The default map of the node's prepared EDS: what it lacks or will not map is left out."""
        return pdos.default_pdos(node_id, axes, synchronous, functools.partial(_is_mappable, od))

    def check_pdos(self, rpdos: Sequence[PdoConfig], tpdos: Sequence[PdoConfig], slots: Sequence[int]) -> list[str]:
        """The drive's PDO limits this node's PDOs break (for the loader; see the report)."""
        return pdos.check_pdos(rpdos, tpdos, slots)

    def parse_axis_options(self, options: Mapping[str, Any]) -> tuple[Mapping[str, Any], Sequence[tuple[str, str]]]:
        return parse_options(options)

    def liveness(self, config: NodeConfig) -> Liveness:
        """Life guarding: the config requires guard_time_ms (``boot.has_heartbeat`` false)."""
        return Liveness.GUARDING if config.guarding else Liveness.NONE

    # -- axes ---------------------------------------------------------------------------------------
    def axis_objects(self, slot: int) -> AxisObjects:
        """0x6063 position actual (r0482; no 0x6064), 0x606C / 0x6077 actual, 0x60FF / 0x6071
        targets, each +0x800 per slot; the target position 0x607A does not exist (never sent)."""
        return replace(AxisObjects.cia402(slot), position_actual=(s.profile_index(s.POSITION_ACTUAL, slot), 0))

    # -- EMCY and parameters ------------------------------------------------------------------------
    def decode_emcy(self, node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent:
        """Without the node's p8743 (a recording's offline decoding): the text, no joint; the
        node's own part (:class:`~.node.S120Node`) knows the joint once the node booted."""
        return emcy.decode(node_id, node_name, data, timestamp, {})

    def stores_parameters(self, config: NodeConfig, index: int, subindex: int) -> bool:
        """Also the parameter window of p0970/p0971/p0976/p0977 (reset, save, restore, save all)."""
        return (super().stores_parameters(config, index, subindex)
                or index in {s.PARAMETER_BASE + number for number in s.STORE_NUMBERS})

    def node(self, config: NodeConfig) -> S120Node:
        """The Control Unit at run time: its DOs (p8743), units and drivers (:mod:`~.node`)."""
        return S120Node(self, config)
