"""Write the EDS files of the generic CiA 402 drive family (one and two axes).

The files in drive_bridge/families/generic402/data/ are what this module writes; they are checked in
so users can read and copy them. Run it again after changing the object list:

    .venv/bin/python -m drive_bridge.families.generic402.edsgen
"""
from __future__ import annotations

from functools import partial

import canopen
from canopen.objectdictionary import datatypes as dt

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import SUPPORT_BITS, Mode
from drive_bridge.families import get_family
from drive_bridge.families.edswriter import Device, EdsFile, Section, container, main, var, variable
from drive_bridge.model import AxisConfig
from drive_bridge.resources import family_data

VENDOR_ID = 0x00000000  # no CiA vendor id: this is a simulated drive
PRODUCT_CODE = 0x00000402
REVISION = 0x00010000
SUPPORTED_MODES = [Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE, Mode.HOMING,
                   Mode.INTERPOLATED_POSITION, Mode.CYCLIC_SYNC_POSITION, Mode.CYCLIC_SYNC_VELOCITY,
                   Mode.CYCLIC_SYNC_TORQUE]


def communication_objects(od: canopen.ObjectDictionary, axes: int) -> None:
    u8, u16, u32 = dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32
    od.add_object(var('Device type', 0x1000, 0, u32, 'ro', 0x00020192))
    od.add_object(var('Error register', 0x1001, 0, u8, 'ro', 0, mappable=True))
    errors = [var(f'Standard error field {i}', 0x1003, i, u32, 'ro', 0) for i in range(1, 9)]
    field = container('Pre-defined error field', 0x1003, errors, array=True)
    field[0].access_type, field[0].default = 'rw', 0
    od.add_object(field)
    od.add_object(var('COB-ID SYNC', 0x1005, 0, u32, 'rw', 0x80))
    od.add_object(var('Communication cycle period', 0x1006, 0, u32, 'rw', 0))
    od.add_object(var('Synchronous window length', 0x1007, 0, u32, 'rw', 0))  # µs, 0 = not used
    od.add_object(var('Manufacturer device name', 0x1008, 0, dt.VISIBLE_STRING, 'const',
                      f'drive_bridge simulated CiA 402 drive ({axes} axis)'))
    od.add_object(var('Manufacturer hardware version', 0x1009, 0, dt.VISIBLE_STRING, 'const', 'sim'))
    od.add_object(var('Manufacturer software version', 0x100A, 0, dt.VISIBLE_STRING, 'const', '1.0'))
    od.add_object(var('Guard time', 0x100C, 0, u16, 'rw', 0))  # node guarding (CiA 301 §7.5.2.8)
    od.add_object(var('Life time factor', 0x100D, 0, u8, 'rw', 0))
    od.add_object(var('COB-ID EMCY', 0x1014, 0, u32, 'rw', 0x80, relative=True))
    od.add_object(var('Inhibit time EMCY', 0x1015, 0, u16, 'rw', 0))
    od.add_object(container('Consumer heartbeat time', 0x1016,
                         [var(f'Consumer heartbeat time {i}', 0x1016, i, u32, 'rw', 0) for i in range(1, 5)],
                         array=True))
    od.add_object(var('Producer heartbeat time', 0x1017, 0, u16, 'rw', 0))
    od.add_object(container('Identity object', 0x1018, [
        var('Vendor-ID', 0x1018, 1, u32, 'ro', VENDOR_ID),
        var('Product code', 0x1018, 2, u32, 'ro', PRODUCT_CODE),
        var('Revision number', 0x1018, 3, u32, 'ro', REVISION),
        var('Serial number', 0x1018, 4, u32, 'ro', 0),
    ]))


def pdo_objects(od: canopen.ObjectDictionary, axes: int) -> None:
    """Four RPDOs and four TPDOs, mapped by default as the family's default map."""
    u8, u16, u32 = dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32
    family_axes = [AxisConfig(f'axis{i}', slot=i) for i in range(axes)]
    rpdos, tpdos = get_family('generic_402').default_pdos(0, family_axes, synchronous=True)
    rx = {p.number: p for p in rpdos}
    tx = {p.number: p for p in tpdos}
    for n in range(1, 5):
        for kind, comm_base, map_base, maps, cob_base in (
                ('RPDO', 0x1400, 0x1600, rx, 0x200), ('TPDO', 0x1800, 0x1A00, tx, 0x180)):
            comm, mapping = comm_base + n - 1, map_base + n - 1
            pdo = maps.get(n)
            cob = cob_base + 0x100 * (n - 1)
            members = [var('COB-ID', comm, 1, u32, 'rw', cob if pdo else cob | 0x80000000, relative=True),
                       var('Transmission type', comm, 2, u8, 'rw', 1 if pdo else 255)]
            if kind == 'TPDO':
                members += [var('Inhibit time', comm, 3, u16, 'rw', 0),
                            var('Compatibility entry', comm, 4, u8, 'rw', 0),
                            var('Event timer', comm, 5, u16, 'rw', 0),
                            var('SYNC start value', comm, 6, u8, 'rw', 0)]
            od.add_object(container(f'{kind}{n} communication parameter', comm, members))
            entries = [e.index << 16 | e.subindex << 8 | e.bits for e in (pdo.mapping if pdo else ())]
            mapped = [var(f'{kind}{n} mapping entry {i}', mapping, i, u32, 'rw',
                          entries[i - 1] if i <= len(entries) else 0) for i in range(1, 9)]
            mapping_record = container(f'{kind}{n} mapping parameter', mapping, mapped)
            mapping_record[0].access_type, mapping_record[0].default = 'rw', len(entries)
            od.add_object(mapping_record)


def axis_objects(od: canopen.ObjectDictionary, slot: int) -> None:
    i8, i16, i32 = dt.INTEGER8, dt.INTEGER16, dt.INTEGER32
    u8, u16, u32 = dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32
    a = partial(obj.for_axis, slot=slot)
    prefix = f'Axis {slot} ' if slot else ''
    supported = sum(1 << SUPPORT_BITS[m] for m in SUPPORTED_MODES)
    simple = [
        (obj.ERROR_CODE, 'Error code', u16, 'ro', 0, True),
        (obj.CONTROLWORD, 'Controlword', u16, 'rw', 0, True),
        (obj.STATUSWORD, 'Statusword', u16, 'ro', 0, True),
        (obj.QUICK_STOP_OPTION, 'Quick stop option code', i16, 'rw', 2, False),
        (obj.SHUTDOWN_OPTION, 'Shutdown option code', i16, 'rw', 0, False),
        (obj.DISABLE_OPERATION_OPTION, 'Disable operation option code', i16, 'rw', 1, False),
        (obj.HALT_OPTION, 'Halt option code', i16, 'rw', 1, False),
        (obj.FAULT_REACTION_OPTION, 'Fault reaction option code', i16, 'rw', 2, False),
        (obj.MODES_OF_OPERATION, 'Modes of operation', i8, 'rw', 0, True),
        (obj.MODES_OF_OPERATION_DISPLAY, 'Modes of operation display', i8, 'ro', 0, True),
        (obj.POSITION_DEMAND, 'Position demand value', i32, 'ro', 0, True),
        (obj.POSITION_ACTUAL, 'Position actual value', i32, 'ro', 0, True),
        (obj.FOLLOWING_ERROR_WINDOW, 'Following error window', u32, 'rw', 20000, False),
        (obj.FOLLOWING_ERROR_TIMEOUT, 'Following error time out', u16, 'rw', 10, False),
        (0x6067, 'Position window', u32, 'rw', 100, False),
        (0x6068, 'Position window time', u16, 'rw', 0, False),
        (obj.VELOCITY_DEMAND, 'Velocity demand value', i32, 'ro', 0, True),
        (obj.VELOCITY_ACTUAL, 'Velocity actual value', i32, 'ro', 0, True),
        (0x606D, 'Velocity window', u16, 'rw', 100, False),
        (0x606E, 'Velocity window time', u16, 'rw', 0, False),
        (obj.TARGET_TORQUE, 'Target torque', i16, 'rw', 0, True),
        (obj.MAX_TORQUE, 'Max torque', u16, 'rw', 3000, True),
        (0x6074, 'Torque demand', i16, 'ro', 0, True),
        (obj.MOTOR_RATED_TORQUE, 'Motor rated torque', u32, 'rw', 1000, False),
        (obj.TORQUE_ACTUAL, 'Torque actual value', i16, 'ro', 0, True),
        (obj.TARGET_POSITION, 'Target position', i32, 'rw', 0, True),
        (obj.HOME_OFFSET, 'Home offset', i32, 'rw', 0, False),
        (obj.MAX_PROFILE_VELOCITY, 'Max profile velocity', u32, 'rw', 200000, True),
        (obj.MAX_MOTOR_SPEED, 'Max motor speed', u32, 'rw', 200000, True),
        (obj.PROFILE_VELOCITY, 'Profile velocity', u32, 'rw', 50000, True),
        (obj.PROFILE_ACCELERATION, 'Profile acceleration', u32, 'rw', 500000, True),
        (obj.PROFILE_DECELERATION, 'Profile deceleration', u32, 'rw', 500000, True),
        (obj.QUICK_STOP_DECELERATION, 'Quick stop deceleration', u32, 'rw', 2000000, True),
        (0x6087, 'Torque slope', u32, 'rw', 10000, True),
        (obj.HOMING_METHOD, 'Homing method', i8, 'rw', 35, True),
        (obj.HOMING_ACCELERATION, 'Homing acceleration', u32, 'rw', 500000, True),
        (obj.POSITION_OFFSET, 'Position offset', i32, 'rw', 0, True),
        (obj.VELOCITY_OFFSET, 'Velocity offset', i32, 'rw', 0, True),
        (obj.TORQUE_OFFSET, 'Torque offset', i16, 'rw', 0, True),
        (obj.INTERPOLATION_SUB_MODE, 'Interpolation sub mode select', i16, 'rw', 0, False),
        (obj.MAX_ACCELERATION, 'Max acceleration', u32, 'rw', 2000000, False),
        (obj.MAX_DECELERATION, 'Max deceleration', u32, 'rw', 2000000, False),
        (obj.FOLLOWING_ERROR_ACTUAL, 'Following error actual value', i32, 'ro', 0, True),
        (obj.TARGET_VELOCITY, 'Target velocity', i32, 'rw', 0, True),
        (obj.SUPPORTED_DRIVE_MODES, 'Supported drive modes', u32, 'ro', supported, False),
    ]
    for index, name, data_type, access, default, mappable in simple:
        od.add_object(var(prefix + name, a(index), 0, data_type, access, default, mappable))
    od.add_object(container(prefix + 'Software position limit', a(obj.SOFTWARE_POSITION_LIMIT), [
        var('Min position limit', a(obj.SOFTWARE_POSITION_LIMIT), 1, i32, 'rw', -(2 ** 31)),
        var('Max position limit', a(obj.SOFTWARE_POSITION_LIMIT), 2, i32, 'rw', 2 ** 31 - 1)], array=True))
    od.add_object(container(prefix + 'Homing speeds', a(obj.HOMING_SPEEDS), [
        var('Speed during search for switch', a(obj.HOMING_SPEEDS), 1, u32, 'rw', 20000, True),
        var('Speed during search for zero', a(obj.HOMING_SPEEDS), 2, u32, 'rw', 5000, True)], array=True))
    od.add_object(container(prefix + 'Interpolation data record', a(obj.INTERPOLATION_DATA_RECORD), [
        var('Interpolation data record 1', a(obj.INTERPOLATION_DATA_RECORD), 1, i32, 'rw', 0, True)],
        array=True))
    od.add_object(container(prefix + 'Interpolation time period', a(obj.INTERPOLATION_TIME_PERIOD), [
        var('Interpolation time period value', a(obj.INTERPOLATION_TIME_PERIOD), 1, u8, 'rw', 4),
        var('Interpolation time index', a(obj.INTERPOLATION_TIME_PERIOD), 2, i8, 'rw', -3)]))
    od.add_object(container(prefix + 'Interpolation data configuration', a(obj.INTERPOLATION_DATA_CONFIGURATION), [
        var('Maximum buffer size', a(obj.INTERPOLATION_DATA_CONFIGURATION), 1, u32, 'ro', 16),
        var('Actual buffer size', a(obj.INTERPOLATION_DATA_CONFIGURATION), 2, u32, 'ro', 16, True),
        var('Buffer organization', a(obj.INTERPOLATION_DATA_CONFIGURATION), 3, u8, 'rw', 0),
        var('Buffer position', a(obj.INTERPOLATION_DATA_CONFIGURATION), 4, u16, 'rw', 0),
        var('Size of data record', a(obj.INTERPOLATION_DATA_CONFIGURATION), 5, u8, 'wo', 4),
        var('Buffer clear', a(obj.INTERPOLATION_DATA_CONFIGURATION), 6, u8, 'wo', 0)]))


def check(reread: canopen.ObjectDictionary) -> None:
    assert variable(reread, 0x1014).default == 0x85, 'COB-ID EMCY must be relative to the node id'


def eds_file(axes: int, name: str) -> EdsFile:
    device = Device('drive_bridge', VENDOR_ID, f'Simulated CiA 402 drive, {axes} axis', PRODUCT_CODE, REVISION,
                    (10, 20, 50, 125, 250, 500, 800, 1000))
    sections: tuple[Section, ...] = (partial(communication_objects, axes=axes), partial(pdo_objects, axes=axes),
                                     *(partial(axis_objects, slot=slot) for slot in range(axes)))
    return EdsFile(family_data('generic402', name), device, sections, check)


FILES = (eds_file(1, 'generic402.eds'), eds_file(2, 'generic402_2axis.eds'))

if __name__ == '__main__':
    main(FILES)
