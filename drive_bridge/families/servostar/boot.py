"""Boot steps of a SERVOSTAR node (shared/drives/servostar-400-600.md §2.8, §5.1, §7).

- free PDOs: a channel whose configured mapping is no library PDO takes its free PDO (36 +
  channel) through the selection object before the master maps it (the mapping objects are
  read-only while a library PDO is selected);
- units and limits: PRBASE (increments per revolution), VLIM (speed limit), PEMAX (following
  error limit), DEC (ramp), 0x6093 (user units of profile position); an axis whose
  ``max_velocity`` exceeds VLIM at the joint is refused, naming both;
- the trajectory period: PTBASE (250 us units) must equal the SYNC period for an axis that
  streams in mode 0xFA (its ``mode`` or ``position_mode``); PTBASE takes effect only after SAVE
  and a restart, so the bridge never writes it: a mismatch fails the boot, naming PTBASE.
"""
from __future__ import annotations

import logging

from drive_bridge.families.ports import NodePort
from drive_bridge.families.servostar import objects as o, pdos
from drive_bridge.families.servostar.errors import ServostarBootError
from drive_bridge.families.servostar.units import DriveUnits

log = logging.getLogger('drive_bridge.families.servostar')


def _read_int(node: NodePort, index: int, subindex: int, signed: bool = True) -> int:
    """An integer object by raw SDO (the object channel is typed by the manual, not every EDS)."""
    data = node.sdo_read_raw(index, subindex)
    return int.from_bytes(data[:4], 'little', signed=signed) if data else 0


def _read_optional(node: NodePort, index: int, subindex: int) -> int | None:
    try:
        return _read_int(node, index, subindex)
    except Exception as exc:  # an optional value: the drive may not have it
        log.debug('node %d: 0x%04X:%02X not read: %s', node.node_id, index, subindex, exc)
        return None


def select_free_pdos(node: NodePort) -> None:
    """Channel n of a mapping that is no library PDO: selection object = 36 + n."""
    for kind, configs in (('RPDO', node.config.rpdo), ('TPDO', node.config.tpdo)):
        for config in configs:
            if pdos.library_number(kind, config) is None:
                node.sdo_write(pdos.select_index(kind, config), 0, pdos.free_number(config))


def read_units(node: NodePort) -> DriveUnits:
    prbase = _read_int(node, o.PRBASE, o.VALUE_SUB)
    if prbase not in (16, 20):
        raise ServostarBootError(f'PRBASE (0x35D1) is {prbase}; the SERVOSTAR takes 16 or 20 bits per revolution')
    numerator = _read_optional(node, o.POSITION_FACTOR, 1)
    feed = _read_optional(node, o.POSITION_FACTOR, 2)
    return DriveUnits(prbase=prbase, vlim_rpm=_read_optional(node, o.VLIM, o.VALUE_SUB),
                      pemax=_read_optional(node, o.POSITION_CONTROLLER, 3),
                      dec_ms=_read_optional(node, o.DEC, o.VALUE_SUB),
                      pp_numerator=numerator or 1 << 20, pp_feed=feed or 10000)


def read_ptbase(node: NodePort) -> float:
    """PTBASE as a period in s."""
    ptbase = _read_int(node, o.PTBASE, o.VALUE_SUB)
    if ptbase <= 0:
        raise ServostarBootError(f'PTBASE (0x35D5) is {ptbase}; expected a positive number of 250 us units')
    return ptbase * o.PTBASE_UNIT


def check_ptbase(period: float, sync_period: float, needed: bool) -> str:
    """The PTBASE problem ('' when none); ``needed``: an axis streams in mode 0xFA."""
    units = round(sync_period / o.PTBASE_UNIT)
    if abs(period - sync_period) <= 1e-6:
        return ''
    hint = (f'PTBASE = {units} (SYNC period / 250 us)' if abs(units * o.PTBASE_UNIT - sync_period) < 1e-9
            and abs(sync_period * 1000 - round(sync_period * 1000)) < 1e-9
            else 'a SYNC period of whole milliseconds and PTBASE = that period / 250 us')
    text = (f'PTBASE (0x35D5) = {round(period / o.PTBASE_UNIT)} ({period * 1000:g} ms) differs from the SYNC period '
            f'{sync_period * 1000:g} ms: the trajectory mode 0xFA takes one setpoint per PTBASE; use {hint}, '
            'then SAVE and restart the drive')
    return text if needed else ''
