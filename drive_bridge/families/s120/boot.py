"""The S120's boot steps (run by the master's boot through the family hooks).

Early (right after the boot-up frame, before the first SDO):

- **NMT enter pre-operational.** With p8684 = 4 the node enters STOPPED after start-up (and after
  the bridge's reset communication), where it answers no SDO; with p8684 = 5 it is OPERATIONAL,
  where PDO parameters must not change. The bridge cannot read p8684 before it can talk SDO, so
  it always sends NMT 0x80 (``000 [80 id]``) first: a no-op in PRE-OPERATIONAL (the factory
  setting 127).

Before the boot SDOs and PDOs (after identity):

- **drive objects**: p8743[slot] of each configured slot (the DO number the EMCYs and the
  parameter window use; 0 means no drive object in that slot: the boot fails naming it);
- **units**: p0408, p0418, r0333, p1082, p1121 of each DO, 0x6094, and whether it has an encoder
  (the axis option ``encoder``, else p0400[0] != 0, else r1300 = 21 / 23) -> the axis' SI scaling;
- **CAN sampling time**: p8848 (the Control Unit's); a cycle shorter than 2 x p8848 is refused
  (the drive would lose telegrams, A08751), naming p8848 and what to set;
- **fault reaction**: p8641 of each DO; 0 (the factory setting: no reaction) is a warning: with
  it a lost bridge stops nothing even with life guarding;
- **PDO limits** (:func:`~drive_bridge.families.s120.pdos.check_pdos`);
- **free COB-IDs**: any valid PDO of the node's configured drive objects that holds a COB-ID one
  of the configured PDOs will use is made invalid first (the drive refuses, or answers twice to,
  one COB-ID on two PDOs; slot 0's default PDOs 3 and 4 hold the COB-IDs slot 1 uses).
"""
from __future__ import annotations

import logging
import time

from drive_bridge.families.ports import NodePort
from drive_bridge.families.s120 import objects as s
from drive_bridge.families.s120.errors import S120BootError
from drive_bridge.families.s120.parameters import read_number
from drive_bridge.families.s120.pdos import check_pdos
from drive_bridge.families.s120.units import DriveUnits

log = logging.getLogger('drive_bridge.families.s120')

NMT_ENTER_PRE_OPERATIONAL = 0x80
NMT_SETTLE = 0.01  # s after the NMT command before the first SDO
COB_INVALID = 0x80000000
COB_MASK = 0x7FF


def enter_pre_operational(node: NodePort) -> None:
    node.send_nmt(NMT_ENTER_PRE_OPERATIONAL)
    time.sleep(NMT_SETTLE)


def _number(value: object, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise S120BootError(f'{what} is not a number ({value!r})')
    return int(value)


def read_drive_objects(node: NodePort) -> dict[int, int]:
    """slot -> DO number (p8743[slot], on the Control Unit) of every configured slot."""
    found: dict[int, int] = {}
    for axis in node.config.axes:
        value = _number(read_number(node, s.CU_DO, s.P_DO_OF_SLOT, axis.slot), f'p8743[{axis.slot}]')
        if value <= 0:
            raise S120BootError(f"axis slot {axis.slot} (joint '{axis.joint}') has no drive object: p8743[{axis.slot}] "
                                f'= {value}; check the slot, or the drive objects configured for CANopen')
        found[axis.slot] = value
    doubles = {do for do in found.values() if list(found.values()).count(do) > 1}
    if doubles:
        raise S120BootError(f'p8743 names DO {sorted(doubles)} for more than one slot: {found}')
    return found


def _aborted(exc: Exception) -> bool:
    """The drive answered with an SDO abort (the parameter does not exist there), not a timeout."""
    return bool(getattr(exc, 'abort_code', 0))


def detect_encoder(node: NodePort, drive_object: int) -> bool:
    """Whether the DO has a commissioned encoder: p0400[0] != 0 (encoder type), or, where the
    window has no p0400, r1300 = 21 / 23 (closed-loop control with encoder)."""
    try:
        return _number(read_number(node, drive_object, s.P_ENCODER_TYPE, 0), 'p0400[0]') != 0
    except Exception as exc:
        if not _aborted(exc):
            raise
    try:
        return _number(read_number(node, drive_object, s.P_CONTROL_MODE), 'r1300') % 2 == 1
    except Exception as exc:
        if not _aborted(exc):
            raise
    log.warning('node %d (%s) DO %d: neither p0400 nor r1300 tells whether an encoder is commissioned; '
                'taking one (velocity in increments/s); set the axis drive option encoder', node.node_id,
                node.name, drive_object)
    return True


def read_units(node: NodePort, drive_object: int, slot: int, encoder: bool | None = None) -> DriveUnits:
    """The DO's units (p0408, p0418, r0333, p1082, p1121, 0x6094 of the slot); ``encoder`` as the
    axis' option says (None: :func:`detect_encoder`)."""
    pulses = _number(read_number(node, drive_object, s.P_ENCODER_PULSES, 0), f'p0408 of DO {drive_object}')
    fine = _number(read_number(node, drive_object, s.P_FINE_RESOLUTION, 0), f'p0418 of DO {drive_object}')
    torque = float(read_number(node, drive_object, s.R_RATED_TORQUE))
    if not torque > 0:
        raise S120BootError(f'r0333 (rated motor torque) of DO {drive_object} is {torque}: the torque objects '
                            '0x6071/0x6077 (per mille of r0333) cannot be scaled; commission the motor data')
    if not 0 <= fine <= 24 or pulses < 0:
        raise S120BootError(f'DO {drive_object}: encoder resolution p0408 = {pulses}, p0418 = {fine} is not usable')
    numerator = divisor = 1
    factor = s.VELOCITY_ENCODER_FACTOR + s.PROFILE_OFFSET * slot
    if node.has_object(factor, 1) and node.has_object(factor, 2):
        numerator = _number(node.sdo_read(factor, 1), f'0x{factor:04X}:01')
        divisor = _number(node.sdo_read(factor, 2), f'0x{factor:04X}:02')
        if numerator <= 0 or divisor <= 0:  # p8798 is 1..2^32-1; 0 is an object without a value
            log.warning('node %d (%s) DO %d: velocity encoder factor 0x%04X = %d/%d (p8798) is not a factor; '
                        'taking 1/1', node.node_id, node.name, drive_object, factor, numerator, divisor)
            numerator = divisor = 1
    speed: float | None = None
    ramp: float | None = None
    try:
        speed = float(read_number(node, drive_object, s.P_MAX_SPEED))
        ramp = float(read_number(node, drive_object, s.P_RAMP_DOWN))
    except Exception as exc:  # only a default for stops: the axis' max_acceleration is the better source
        log.info('node %d (%s) DO %d: p1082/p1121 not read (%s); stops use the axis limits', node.node_id,
                 node.name, drive_object, exc)
    with_encoder = detect_encoder(node, drive_object) if encoder is None else encoder
    return DriveUnits(pulses, fine, torque, with_encoder, numerator, divisor, speed, ramp)


def check_sampling_time(node: NodePort, cycle_period: float | None) -> float:
    """p8848 (ms); S120BootError when the bridge's cycle is shorter than twice it."""
    sampling = float(read_number(node, s.CU_DO, s.P_SAMPLING_TIME))
    if cycle_period is None or sampling <= 0:
        return sampling
    needed = 2 * sampling
    if cycle_period * 1000.0 + 1e-6 < needed:
        raise S120BootError(
            f'the bridge cycle (SYNC period) of {cycle_period * 1000:g} ms is shorter than 2 x p8848 = {needed:g} ms '
            f'(p8848 = {sampling:g} ms, the drive\'s CAN sampling time): the drive would lose telegrams (A08751). '
            f'Set master.sync_period to at least {round(needed * 1000)} us, or set p8848 on the drive to at most '
            f'{cycle_period * 500:g} ms (p0009 = 3, p8848, save, p0009 = 0: the Control Unit reboots)')
    return sampling


def warn_fault_reaction(node: NodePort, drive_objects: dict[int, int]) -> list[int]:
    """p8641 of each DO; the DOs with 0 (no reaction) are warned about and returned."""
    silent = []
    for slot, do in sorted(drive_objects.items()):
        reaction = _number(read_number(node, do, s.P_ABORT_CONNECTION), f'p8641 of DO {do}')
        if reaction == 0:
            silent.append(do)
            log.warning('node %d (%s) DO %d (slot %d): p8641 = 0, no reaction to a CAN communication error: if the '
                        'bridge is lost (life guarding times out) the drive runs on with its last setpoint. Set '
                        'p8641 = 1 (OFF1), 2 (OFF2) or 3 (OFF3): ~/param_write p8641 with drive_object %d, then '
                        '~/param_save', node.node_id, node.name, do, slot, do)
    if not node.config.guarding:
        log.warning('node %d (%s): no life guarding (guard_time_ms 0): the drive cannot notice a lost bridge',
                    node.node_id, node.name)
    return silent


def check_limits(node: NodePort) -> None:
    problems = check_pdos(node.config.rpdo, node.config.tpdo, [a.slot for a in node.config.axes])
    if problems:
        raise S120BootError('; '.join(problems))


def free_cob_ids(node: NodePort) -> None:
    """Invalidate every valid PDO of the configured slots whose COB-ID a configured PDO of
    another number will use."""
    wanted: dict[tuple[int, int], int] = {}  # (comm base, number) -> COB-ID
    for base, configs in ((s.RPDO_COMM, node.config.rpdo), (s.TPDO_COMM, node.config.tpdo)):
        for config in configs:
            if config.enabled:
                wanted[(base, config.number)] = config.cob_id & COB_MASK
    taken = set(wanted.values())
    written: list[str] = []
    slots = sorted({a.slot for a in node.config.axes} | {0})
    for base in (s.RPDO_COMM, s.TPDO_COMM):
        for slot in slots:
            for k in range(s.PDOS_PER_SLOT):
                number = s.pdo_number(slot, k)
                index = base + number - 1
                if not node.has_object(index, 1):
                    continue
                cob = _number(node.sdo_read(index, 1), f'0x{index:04X}:01')
                if cob & COB_INVALID or cob & COB_MASK not in taken or wanted.get((base, number)) == cob & COB_MASK:
                    continue
                node.sdo_write(index, 1, cob | COB_INVALID)
                written.append(f'0x{index:04X}')
    if written:
        log.info('node %d (%s): PDOs %s invalidated: their COB-IDs are the configured ones of other PDOs',
                 node.node_id, node.name, ', '.join(written))
