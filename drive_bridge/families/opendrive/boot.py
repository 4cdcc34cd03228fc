"""The OPEN drive's boot steps (run by the master's boot through the node's hooks, :mod:`~.node`):
fieldbus RUN low and references 0 before anything else (RUN starts high at power-on), C52 = 1
checked (else the drive ignores every CAN reference), the representation words of the velocity
and torque feedback read (0x2004 / 0x2003), the life time factor kept within 32767 / f_pwm, and
the logic word 0x201F read back after the boot SDOs."""
from __future__ import annotations

import logging

from drive_bridge.families.opendrive import objects as od, representation
from drive_bridge.families.opendrive.errors import OpenDriveBootError
from drive_bridge.families.opendrive.options import DriveOptions
from drive_bridge.families.ports import NodePort

log = logging.getLogger('drive_bridge.families.opendrive')


def _number(value: object, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise OpenDriveBootError(f'{what} is not a number ({value!r})')
    return int(value)


def options_of(node: NodePort) -> DriveOptions:
    if not node.config.axes:
        raise OpenDriveBootError('the node has no axis, so its drive settings (array_offset, f_pwm, the '
                                 'alarm reset function) are unknown; give it one axis')
    return DriveOptions.of(node.config.axes[0].drive)


def stop_drive(node: NodePort) -> None:
    """Fieldbus RUN low (the bits the bridge owns cleared, the others kept as read) and every
    reference 0: the drive starts with RUN high, and may still hold a previous master's
    references."""
    options = options_of(node)
    word = _number(node.sdo_read(od.INPUTS_STANDARD_WR, 0), '0x201F')
    owned = od.RUN_BIT | 1 << options.alarm_reset_function
    node.sdo_write(od.INPUTS_STANDARD_WR, 0, word & ~owned & 0xFFFFFFFF)
    for index in (*od.SPEED_REFERENCES, od.TORQUE_REFERENCE):
        if node.has_object(index):
            node.sdo_write(index, 0, 0)


def check_c52(node: NodePort) -> None:
    offset = options_of(node).array_offset
    value = _number(node.sdo_read(od.CONNECTIONS, od.C52 + offset), f'C52 (0x200E:{od.C52 + offset:02X})')
    if value != 1:
        raise OpenDriveBootError(f'C52 = {value} (0x200E:{od.C52 + offset:02X}): the drive ignores the CAN '
                                 'references 0x201A-0x201D unless C52 = 1; set C52 = 1 (~/param_write C52 1, '
                                 'then ~/param_save) and restart the drive')


def read_representations(node: NodePort) -> representation.Scaling:
    """The scaling of the velocity and torque feedback by their representation words (module
    representation): one upload of 0x2004 (Tab_osc) / 0x2003 (Tab_int) per table used."""
    options = options_of(node)
    tables: dict[int, tuple[int, ...]] = {}
    found: dict[str, tuple[int, float]] = {}
    for name, quantity in (('actual_velocity', options.actual_velocity), ('actual_torque', options.actual_torque)):
        if quantity is None:
            continue
        index = representation.FORMATS_OF[quantity.index]
        if index not in tables:
            try:
                tables[index] = representation.words(node.sdo_read_raw(index, 0))
            except ValueError as error:
                raise OpenDriveBootError(f'0x{index:04X}: {error}') from None
        word = tables[index][quantity.element]
        try:
            found[name] = word, representation.full_scale(word)
        except ValueError as error:
            raise OpenDriveBootError(f'{name} {quantity.describe(options.array_offset)}: {error} (0x{index:04X} '
                                     f'word {quantity.element}); the bridge cannot scale it') from None
    velocity = found.get('actual_velocity')
    torque = found.get('actual_torque')
    scaling = representation.Scaling(
        velocity[1] if velocity else representation.Scaling.velocity_full_scale,
        torque[1] if torque else representation.Scaling.torque_full_scale,
        velocity[0] if velocity else None, torque[0] if torque else None)
    log.info('node %d (%s): feedback scaling from the representation words: velocity %s, torque %s',
             node.node_id, node.name, *(f'0x{w[0]:04X} ({w[1]:g} = 100 %)' if w else 'none'
                                        for w in (velocity, torque)))
    return scaling


def clamp_life_time(node: NodePort) -> None:
    """The drive keeps at most 32767 / f_pwm s of node life time: write a life time factor
    within it (and warn) when guard time x factor is longer."""
    config = node.config
    if not config.guarding:
        return
    limit_ms = options_of(node).life_time_limit_ms
    life_ms = config.guard_time_ms * config.life_time_factor
    if life_ms <= limit_ms:
        return
    factor = max(1, int(limit_ms // config.guard_time_ms))
    log.warning('node %d (%s): node life time %d ms (guard time %d ms x %d) is longer than the drive keeps '
                '(32767 / f_pwm = %.0f ms); life time factor written as %d (%d ms)%s', node.node_id, node.name,
                life_ms, config.guard_time_ms, config.life_time_factor, limit_ms, factor,
                factor * config.guard_time_ms,
                '; the guard time alone is longer: shorten guard_time_ms' if factor * config.guard_time_ms
                > limit_ms else '')
    node.sdo_write(od.LIFE_TIME_FACTOR, 0, factor)


def read_logic_word(node: NodePort) -> int:
    """After the boot SDOs (which may set logic functions of the fieldbus channel): the
    driver sends the bits it does not own as they are now (RUN and the alarm reset function
    low again, should a boot SDO have set them); returns the word as read."""
    word = _number(node.sdo_read(od.INPUTS_STANDARD_WR, 0), '0x201F')
    owned = od.RUN_BIT | 1 << options_of(node).alarm_reset_function
    if word & owned:
        node.sdo_write(od.INPUTS_STANDARD_WR, 0, word & ~owned & 0xFFFFFFFF)
    return word
