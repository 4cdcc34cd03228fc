"""One SERVOSTAR at run time: its axis' driver, the cycle it runs at and the units the boot
read (PRBASE, VLIM, PEMAX, DEC, PTBASE); the boot steps that read them and check the axis and
the SYNC period against them, and the parameter access."""
from __future__ import annotations

import logging
from collections.abc import Sequence

from drive_bridge.families.node import FamilyNode, NodeFamily
from drive_bridge.families.parameters import ParameterPort
from drive_bridge.families.ports import BootStep, NodePort
from drive_bridge.families.servostar import boot, objects as o
from drive_bridge.families.servostar.driver import ServostarQuirks, mode_label
from drive_bridge.families.servostar.errors import ServostarBootError
from drive_bridge.families.servostar.parameters import ServostarParameters
from drive_bridge.families.servostar.units import DriveUnits
from drive_bridge.model import AxisConfig, NodeConfig

log = logging.getLogger('drive_bridge.families.servostar')


class ServostarNode(FamilyNode):
    """One SERVOSTAR 400/600 node (one axis)."""

    def __init__(self, family: NodeFamily, config: NodeConfig) -> None:
        super().__init__(family, config)
        self.drivers: dict[int, ServostarQuirks] = {}  # by slot
        self.units: DriveUnits | None = None  # as the last boot read them

    def axis_quirks(self, axis: AxisConfig) -> ServostarQuirks:
        driver = ServostarQuirks(axis)
        self.drivers[axis.slot] = driver
        return driver

    # -- boot -----------------------------------------------------------------------------------------
    def boot_steps_before(self, node: NodePort) -> Sequence[BootStep]:
        return (('free PDOs 37-40 (0x2600 / 0x2A00)', boot.select_free_pdos),
                ('units and limits PRBASE / VLIM / PEMAX', self._read_units),
                ('trajectory period PTBASE', self._check_ptbase))

    def _read_units(self, node: NodePort) -> None:
        units = boot.read_units(node)
        for axis in node.config.axes:
            driver = self.drivers.get(axis.slot)
            vlim = units.joint_speed_limit(driver.options, axis.joint_type) if driver is not None else None
            limit = axis.limits.max_velocity
            if vlim is not None and limit is not None and limit > vlim * (1 + 1e-9):
                raise ServostarBootError(
                    f"joint {axis.joint!r}: max_velocity {limit:g} exceeds the drive's speed limit VLIM (0x3622) = "
                    f'{units.vlim_rpm:g} rpm ({vlim:.6g} at the joint): the drive faults on steps beyond '
                    'VLIM x period; lower max_velocity or raise VLIM')
        log.info('node %d (%s): %s', node.node_id, node.name, units.describe())
        self.units = units

    def _check_ptbase(self, node: NodePort) -> None:
        period = boot.read_ptbase(node)
        units = self.units
        sync = self.cycle_period
        for axis in node.config.axes:
            driver = self.drivers.get(axis.slot)
            if driver is None:
                continue
            if units is not None:
                driver.apply_units(units, period)
            if sync is None:
                continue
            streams = o.MODE_TRAJECTORY in (axis.mode, axis.position_mode)
            problem = boot.check_ptbase(period, sync, streams)
            if problem:
                raise ServostarBootError(f'joint {axis.joint!r} streams in mode {mode_label(o.MODE_TRAJECTORY)}: '
                                              f'{problem}')
            if abs(period - sync) > 1e-6:
                log.warning('node %d (%s): PTBASE is %g ms, the SYNC period %g ms: mode 0xFA will be refused',
                            node.node_id, node.name, period * 1000, sync * 1000)

    # -- parameters ---------------------------------------------------------------------------------
    def parameters(self, port: ParameterPort) -> ServostarParameters:
        """ASCII parameters of the object channel 0x3500+ by name."""
        config: NodeConfig | None = getattr(port, 'config', None)
        return ServostarParameters(port, config.od if config is not None else None)
