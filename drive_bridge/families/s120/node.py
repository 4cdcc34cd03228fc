"""One S120 Control Unit at run time: which drive object sits in which axis slot (p8743, read
at boot), the axes' drivers and the cycle they run at; the boot steps that read them, the EMCY
decoding and the parameter access that need them."""
from __future__ import annotations

import logging
from collections.abc import Sequence

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.families.node import FamilyNode, NodeFamily
from drive_bridge.families.parameters import ParameterPort
from drive_bridge.families.ports import BootStep, NodePort
from drive_bridge.families.s120 import boot, emcy, objects as s
from drive_bridge.families.s120.driver import S120Quirks
from drive_bridge.families.s120.parameters import S120Parameters, read_number
from drive_bridge.model import AxisConfig, NodeConfig

log = logging.getLogger('drive_bridge.families.s120')


class S120Node(FamilyNode):
    """One node (a Control Unit) with up to 8 drive objects, one per axis slot."""

    def __init__(self, family: NodeFamily, config: NodeConfig) -> None:
        super().__init__(family, config)
        self.drivers: dict[int, S120Quirks] = {}  # by slot
        self.slot_of_do: dict[int, int] = {}  # DO number -> slot (p8743, read at boot)
        self.do_of_slot: dict[int, int] = {}

    # -- the joint driver ----------------------------------------------------------------------------
    def axis_quirks(self, axis: AxisConfig) -> S120Quirks:
        driver = S120Quirks(axis)
        self.drivers[axis.slot] = driver
        return driver

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
        self.do_of_slot = found
        self.slot_of_do = {do: slot for slot, do in found.items()}

    def _read_units(self, node: NodePort) -> None:
        for slot, do in sorted(self.do_of_slot.items()):
            driver = self.drivers.get(slot)
            units = boot.read_units(node, do, slot, driver.options.encoder if driver is not None else None)
            if driver is not None:
                driver.apply_units(units, do)
            log.info('node %d (%s) slot %d = DO %d: %s', node.node_id, node.name, slot, do, units.describe())

    def _check_sampling_time(self, node: NodePort) -> None:
        boot.check_sampling_time(node, self.cycle_period)

    def _check_fault_reaction(self, node: NodePort) -> None:
        boot.warn_fault_reaction(node, self.do_of_slot)

    # -- EMCY and parameters ------------------------------------------------------------------------
    def decode_emcy(self, data: bytes, timestamp: float) -> EmcyEvent:
        """To the joint by the EMCY's DO number (p8743, known once the node booted)."""
        return emcy.decode(self.node_id, self.name, data, timestamp, self.slot_of_do)

    def drive_object_of(self, slot: int) -> int | None:
        """The DO number of an axis slot (p8743, known once the node booted)."""
        return self.do_of_slot.get(slot)

    def parameters(self, port: ParameterPort) -> S120Parameters:
        """p/r parameters of any drive object (0x2000 + number, selector p8630)."""
        config: NodeConfig | None = getattr(port, 'config', None)

        def drive_object_of(slot: int | None) -> int:
            if slot is None:
                if config is None or not config.axes:
                    raise LookupError('the node has no configured axis')
                slot = config.axes[0].slot
            known = self.do_of_slot.get(slot)
            if known is not None:
                return known
            return int(read_number(port, s.CU_DO, s.P_DO_OF_SLOT, slot))
        return S120Parameters(port, drive_object_of)
