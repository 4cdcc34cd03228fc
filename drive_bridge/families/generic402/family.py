"""The default family, registered as ``generic_402``: any CiA 402 drive, with the standard PDO
map where its EDS takes it, else one fitted to the EDS."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from canopen import ObjectDictionary

from drive_bridge.cia301.cob import predefined_cob_id
from drive_bridge.cia402 import objects as obj
from drive_bridge.families.generic402.pdomap import plan
from drive_bridge.families.interface import DriveFamily, PdoPlan
from drive_bridge.families.registry import register_family
from drive_bridge.families.traits import AxisTraits, ModeTraits
from drive_bridge.model import AxisConfig, PdoConfig, PdoEntry
from drive_bridge.resources import family_data

SYNC_EVERY_CYCLE = 1
EVENT_DRIVEN = 255


def _entries(slot: int, *objects: tuple[int, int]) -> tuple[PdoEntry, ...]:
    return tuple(PdoEntry(obj.for_axis(index, slot), 0, bits) for index, bits in objects)


@register_family
class Generic402(DriveFamily):
    """The standard map, used where the EDS takes it: two RPDOs and two TPDOs per axis
    carry everything every standard mode needs, so modes can change on the fly without
    remapping:

    - RPDO 2k+1: controlword, modes of operation, target torque (40 bits)
    - RPDO 2k+2: target position, target velocity (64 bits)
    - TPDO 2k+1: statusword, modes of operation display, torque actual (40 bits)
    - TPDO 2k+2: position actual, velocity actual (64 bits)

    A one-axis node also gets RPDO 3 with the interpolation data record 0x60C1:1, sent
    only when written (linear interpolated position mode writes it every cycle).
    """

    name = 'generic_402'
    description = 'CiA 402 drive (default PDO map fitted to its EDS)'
    default_eds = family_data('generic402', 'generic402.eds')
    axes = AxisTraits(max_count=2)  # the predefined connection set has four PDOs each way
    modes = ModeTraits(from_drive=True)

    def plan_pdos(self, node_id: int, axes: Sequence[AxisConfig], synchronous: bool,
                  od: ObjectDictionary) -> PdoPlan:
        """The standard map below where the EDS takes it, else one fitted to the EDS."""
        return plan(od, node_id, axes, synchronous, lambda: self.default_pdos(node_id, axes, synchronous))

    def eds_for(self, axis_count: int) -> Path | None:
        return family_data('generic402', 'generic402_2axis.eds') if axis_count == 2 else self.default_eds

    def default_pdos(self, node_id: int, axes: Sequence[AxisConfig],
                     synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        rpdos: list[PdoConfig] = []
        tpdos: list[PdoConfig] = []
        rx_type = SYNC_EVERY_CYCLE if synchronous else EVENT_DRIVEN
        tx_type = SYNC_EVERY_CYCLE if synchronous else EVENT_DRIVEN
        timer = 0 if synchronous else 10  # ms: event-driven TPDOs also refresh periodically
        for k, axis in enumerate(axes):
            s = axis.slot
            numbered = (
                (2 * k + 1,
                 _entries(s, (obj.CONTROLWORD, 16), (obj.MODES_OF_OPERATION, 8), (obj.TARGET_TORQUE, 16)),
                 _entries(s, (obj.STATUSWORD, 16), (obj.MODES_OF_OPERATION_DISPLAY, 8), (obj.TORQUE_ACTUAL, 16))),
                (2 * k + 2,
                 _entries(s, (obj.TARGET_POSITION, 32), (obj.TARGET_VELOCITY, 32)),
                 _entries(s, (obj.POSITION_ACTUAL, 32), (obj.VELOCITY_ACTUAL, 32))),
            )
            for number, rx_map, tx_map in numbered:
                rpdos.append(PdoConfig(number, predefined_cob_id('rpdo', number, node_id),
                                       transmission=rx_type, mapping=rx_map))
                tpdos.append(PdoConfig(number, predefined_cob_id('tpdo', number, node_id),
                                       transmission=tx_type, event_timer=timer, mapping=tx_map))
        if len(axes) == 1:
            ip_point = _entries(axes[0].slot, (obj.INTERPOLATION_DATA_RECORD, 32))
            ip_point = tuple(PdoEntry(e.index, 1, e.bits) for e in ip_point)
            rpdos.append(PdoConfig(3, predefined_cob_id('rpdo', 3, node_id), transmission=rx_type, mapping=ip_point))
        return tuple(rpdos), tuple(tpdos)
