"""The ``opendrive`` family: OPEN drive converters over CANopen (CiA 301 only; shared/drives/
opendrive.md, from the drive's CAN appendix).

What the bridge knows beyond the EDS (drive_bridge/families/opendrive/data/opendrive.eds, written by
families/opendrive/edsgen.py):

- no CiA 402: the joint driver is :class:`~drive_bridge.families.opendrive.driver.RunLogicDriver`
  (enable = the RUN logic function, references 0x201A/0x201D and 0x201C, alarms 0x2018);
- one axis per node; no heartbeat: always node guarding (the config must give
  ``guard_time_ms``); the drive clamps its node life time to 32767 / f_pwm s, so the boot
  writes a life time factor that keeps within it (and says so);
- PDO rules of its own: TPDO type 0 is sent at *every* SYNC, 254 on the event timer only;
  RPDO types 0..240 apply at the next SYNC, 254 at once (255 is not listed); the RPDO
  communication records manage sub-indices 1 and 2 only (the bridge writes nothing else);
- boot (:mod:`~.boot`, run by the node's part :mod:`~.node`): fieldbus RUN low and references 0
  before anything else (RUN starts high at power-on), C52 = 1 checked (else the drive ignores
  every CAN reference), the representation words of the velocity and torque feedback read
  (0x2004 / 0x2003: the feedback's scale, not a fixed 16384 = n_MAX; ``representation``), the
  life time clamp;
- EMCY 0x10xx = an alarm (bytes 3-4 the alarm word), 0x00xx = alarms reset;
- parameters P/C by number with their format words (``parameters``).

Default PDO map (the element sub-indices follow the axis' ``array_offset``):

======  ======================================================================  =====
PDO     objects                                                                 bytes
======  ======================================================================  =====
RPDO1   0x201F logic word (RUN, alarm reset), speed reference 0x201A or 0x201D,   8
        torque reference 0x201C (type 1: applied at the next SYNC)
TPDO1   0x2021 logic read-back (RUN), 0x2018 alarms, actual velocity element       8
        (type 0: every SYNC)
TPDO2   actual torque element, position element (those configured; type 0)       2-4
======  ======================================================================  =====

The torque limit 0x201B does not fit RPDO1 and is left to the drive (its power-on value).
Without SYNC (``master.sync_period: 0``) the RPDO is type 254 (applied at once) and the
TPDOs type 254 with a 10 ms event timer.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from drive_bridge.cia301.cob import predefined_cob_id
from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.modes import Mode
from drive_bridge.families.interface import DriveFamily, Liveness
from drive_bridge.families.opendrive import alarms, objects as od
from drive_bridge.families.opendrive.node import OpenDriveNode
from drive_bridge.families.opendrive.options import DriveOptions, parse_options
from drive_bridge.families.opendrive.parameters import SAFETY_PARAMETERS
from drive_bridge.families.registry import register_family
from drive_bridge.families.traits import AxisTraits, BootTraits, ModeTraits, PdoTraits
from drive_bridge.model import AxisConfig, NodeConfig, PdoConfig, PdoEntry
from drive_bridge.resources import family_data

SYNC_NEXT = 1  # RPDO: applied at the next SYNC
APPLY_AT_ONCE = 254  # RPDO: applied at once (255 is not listed for this drive)
EVERY_SYNC = 0  # TPDO: refreshed and sent at every SYNC (not CiA 301's acyclic meaning)
EVENT_TIMER = 254  # TPDO: sent every event-timer period
EVENT_TIMER_MS = 10


def _entry(index: int, bits: int, subindex: int = 0) -> PdoEntry:
    return PdoEntry(index, subindex, bits)


@register_family
class OpenDrive(DriveFamily):
    """OPEN drive (CiA 301, RUN logic, references 0x201A-0x201D), one axis per node."""

    name = 'opendrive'
    description = 'OPEN drive converter (CiA 301 only: RUN logic, CAN references, node guarding)'
    # the drive keeps its last RUN and references when its master goes silent (appendix §2.4: no
    # action on a life-guarding timeout in the default firmware, no heartbeat, no RPDO timeout)
    boot = BootTraits(has_heartbeat=False, runs_on_without_master=True)
    default_eds = family_data('opendrive', 'opendrive.eds')
    # the driver scales from the axis' drive settings (n_MAX, T_nom, ...)
    axes = AxisTraits(has_cia402=False, max_count=1, uses_axis_scaling=False)
    emcy_texts = alarms.EMCY_TEXTS
    modes = ModeTraits(accepted=frozenset({Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE}),
                       defaults={'mode': 'pv', 'velocity_mode': 'pv', 'effort_mode': 'pt'})
    # RPDO records manage sub 1 and 2 only; TPDO records 1..5 (4 reserved); no SYNC start value
    pdo = PdoTraits(comm_subindices=frozenset({1, 2, 3, 5}))

    # -- configuration ----------------------------------------------------------------------
    def eds_for(self, axis_count: int) -> Path | None:
        return self.default_eds

    def parse_axis_options(self, options: Mapping[str, Any]) -> tuple[Mapping[str, Any], Sequence[tuple[str, str]]]:
        return parse_options(options)

    def liveness(self, config: NodeConfig) -> Liveness:
        """Always node guarding (the drive has no heartbeat); the config requires guard_time_ms."""
        return Liveness.GUARDING if config.guarding else Liveness.NONE

    def default_pdos(self, node_id: int, axes: Sequence[AxisConfig],
                     synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        if len(axes) > self.axes.max_count:
            raise ValueError(f'an OPEN drive drives one axis, {len(axes)} given')
        if not axes:
            return (), ()
        try:
            options = DriveOptions.of(axes[0].drive)
        except ValueError:
            return (), ()  # the axis' drive settings are incomplete: the loader reports them
        offset = options.array_offset
        rx_type = SYNC_NEXT if synchronous else APPLY_AT_ONCE
        tx_type = EVERY_SYNC if synchronous else EVENT_TIMER
        timer = 0 if synchronous else EVENT_TIMER_MS
        velocity = options.actual_velocity.key(offset)
        rx = (_entry(od.INPUTS_STANDARD_WR, 32), _entry(options.speed_reference, 16), _entry(od.TORQUE_REFERENCE, 16))
        tx1 = (_entry(od.INPUTS_STANDARD_RD, 32), _entry(od.ALARMS, 16), _entry(velocity[0], 16, velocity[1]))
        tx2 = tuple(_entry(quantity.index, 16, quantity.element + offset)
                    for quantity in (options.actual_torque, options.position) if quantity is not None)
        rpdos = (PdoConfig(1, predefined_cob_id('rpdo', 1, node_id), transmission=rx_type, mapping=rx),)
        tpdos = tuple(PdoConfig(n, predefined_cob_id('tpdo', n, node_id), transmission=tx_type, event_timer=timer,
                                mapping=m) for n, m in ((1, tx1), (2, tx2)) if m)
        return rpdos, tpdos

    def safety_object(self, config: NodeConfig | None, index: int, subindex: int) -> str | None:
        """CiA 301's, and P162 (node id) and C48 (bit rate) in the parameter arrays."""
        offset = 0
        if config is not None and config.axes:
            try:
                offset = DriveOptions.of(config.axes[0].drive).array_offset
            except ValueError:
                offset = 0
        for (letter, number), text in SAFETY_PARAMETERS.items():
            if (index, subindex) == ((od.PARAMETERS if letter == 'P' else od.CONNECTIONS), number + offset):
                return text
        return super().safety_object(config, index, subindex)

    # -- EMCY and parameters --------------------------------------------------------------------
    def decode_emcy(self, node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent:
        return alarms.decode(node_id, node_name, data, timestamp)

    def stores_parameters(self, config: NodeConfig, index: int, subindex: int) -> bool:
        """Also C63 (save to non-volatile memory), at the sub-index the axis' array_offset gives
        (both candidates while it is unknown)."""
        if super().stores_parameters(config, index, subindex):
            return True
        offsets = {int(config.axes[0].drive['array_offset'])} if config.axes and \
            'array_offset' in config.axes[0].drive else {0, 1}
        return index == od.CONNECTIONS and subindex - od.C63 in offsets

    def node(self, config: NodeConfig) -> OpenDriveNode:
        """The drive at run time: its driver, boot steps, stop and parameters (:mod:`~.node`)."""
        return OpenDriveNode(self, config)
