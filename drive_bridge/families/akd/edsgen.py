"""Write the EDS of the Kollmorgen AKD drive family: drive_bridge/families/akd/data/akd.eds.

Kollmorgen publishes no AKD EDS that we could find (shared/realdata/SOURCES.md), so this
file is built from the AKD CANopen manual (rev. F, 903-200004-03) as summarised in
shared/drives/akd.md §8: the communication area, the profile area and the manufacturer
objects that the bridge, the simulator (drive_bridge/sim/akd/) or the manual's worked
examples touch. Everything else of the manual's 0x2000-0x5FFF list (control-loop gains,
motor data, Wake & Shake, ...) is left out: the simulator has nothing behind it.

Run it again after changing the object list::

    .venv/bin/python -m drive_bridge.families.akd.edsgen

Defaults are the manual's where it gives one (the PDO maps are the AKD's *factory* maps,
§6.3.1.3/§6.3.2.3, not the bridge's default map: the manual's examples rely on them).

Where §6 (object descriptions) and §7 (dictionary appendix) of the manual disagree
(akd.md §12 item 9) this file chooses, by (1) what the manual's own worked examples do,
(2) CiA 301/402, (3) what a master needs:

==========================  ==========  ==========  =============================================
object                      §6          §7          chosen, and why
==========================  ==========  ==========  =============================================
0x60C0 sub-mode select      INT16       INT8        INT16: CiA 402; the PVT example writes it with
                                                    a 2-byte download (0x2B)
0x1600-03/1A00-03 sub0      RW          RO          RW: every example writes sub0 (clear, count)
0x1014 COB-ID EMCY          RO          RW          RW: CiA 301 (the sim refuses an id change
                                                    while the EMCY is valid, as CiA 301 asks)
0x6040 controlword          RW          WO          RW: CiA 402; masters read it back
0x6041 statusword           RW          RO          RO: CiA 402; a statusword cannot be written
0x6063/0x6064 position      R/W         RO          RO: CiA 402; actual values
0x60C4:2 actual buffer size PDO yes     PDO no      PDO yes: CiA 402; the bridge feeds PVT from it
0x60C4:5/:6                 "L"         WO          WO: CiA 402
==========================  ==========  ==========  =============================================

Other choices where the manual is silent or self-contradictory:

- 0x60C2:2 (interpolation time index) is INTEGER8 with default -3 (CiA 402; the examples
  write it with a 1-byte download of 0xFD); the appendix's INT16 is not followed. 0x60C2:1
  defaults to 1, so the power-on period is 1 ms (the manual's table); the PLL section's
  "default sample time 2 ms" is not followed.
- 0x60C1 is a RECORD (sub2, the time, is UNSIGNED32 while subs 1 and 3 are INTEGER32).
- 0x6060 / 0x6061 have no default in the manual: 0 here (no mode until the master picks one).
- 0x6072 max torque has no default in the manual: 3000 per mille (300 % of rated torque);
  0x6065 following error window 0 = monitoring off (§6.11). 0x606D velocity window 1000
  counts/s, 0x35C6 MT.TPOSWND (in-position window) 1000 counts: no default in the manual.
- 0x3501 DRV.ACC / 0x3522 DRV.DEC (100 rev/s^2) and 0x3440:1 CS.DEC (200 rev/s^2) in counts
  (2^20 per revolution): no default in the manual. The simulator uses DRV.ACC/DRV.DEC where
  0x6083/0x6084 are 0 (their manual default) and CS.DEC as its quick-stop ramp (there is no
  0x6085 on the AKD).
- 0x6099:1/:2 homing speeds: "the equivalent of 60 rpm" = 2^20 counts/s and 1/8 of it.
- 0x1018:2 product code: the four ASCII characters "M006" (an MV drive of 6 A) packed
  little-endian, as 0x1008 shows them. 0x100A: "0.20", matching 0x1018:3 = 0x00140000
  (CAN version 0.20). 0x1009 is absent: "will be supported in future" (§6.2.1.8).
- 0x2100 (the 4-byte dummy of §7.2.2.1, not in the dictionary) is UNSIGNED32, RW, mappable.
- 0x204C:1/:2 (pv scaling) are INTEGER32 limited to -32768..32767 (0 is refused by the sim).
- Objects the manual references but does not define (0x6093, 0x6097, 0x6086, 0x100E) and the
  CiA 402 objects the AKD lacks (0x603F, 0x605A-0x605E, 0x6062, 0x6066-0x6068, 0x6085,
  0x607F, 0x6080, 0x60C5, 0x60C6, ...) are absent, so a master gets 0x06020000 for them.
- Left out although in the manual (nothing simulated behind them): touch probe 0x60B8-0x60BD
  and 0x60D0, latches 0x20A0-0x20A6, the 0x1026 console, 0x2071 / 0x2077.
- 0x2026 is the ASCII channel (sub 1 command WO, sub 2 response RO, 4 characters each, §9.11):
  the family's parameter access (families/akd/parameters.py) talks through it.
"""
from __future__ import annotations

import canopen
from canopen.objectdictionary import datatypes as dt

from drive_bridge.families.edswriter import Device, EdsFile, container, main, mapping_record, members, var, variable
from drive_bridge.resources import family_data

VENDOR_ID = 0x0000006A  # "Danaher Motion" (§6.2.1.17)
PRODUCT_CODE = int.from_bytes(b'M006', 'little')
REVISION = 0x00140000  # high word: CAN version 0.20
DEVICE_TYPE = 0x00020192  # servo drive, CiA 402
SUPPORTED_DRIVE_MODES = 0x65  # pp, pv, hm, ip (the AKD does not advertise tq and csp)
COUNTS_PER_REV = 2 ** 20

I8, I16, I32 = dt.INTEGER8, dt.INTEGER16, dt.INTEGER32
U8, U16, U32 = dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32
VS = dt.VISIBLE_STRING

# AKD factory PDO maps (§6.3.1.3, §6.3.2.3): PDO number -> mapping entries
FACTORY_RPDOS = {1: [0x60400010], 2: [0x60400010, 0x60600008], 3: [0x60400010, 0x607A0020],
                 4: [0x60400010, 0x60FF0020]}
FACTORY_TPDOS = {1: [0x60410010], 2: [0x60410010, 0x60610008], 3: [0x60410010, 0x60640020],
                 4: [0x60410010, 0x606C0020]}


def communication(od: canopen.ObjectDictionary) -> None:
    add = od.add_object
    add(var('Device type', 0x1000, 0, U32, 'ro', DEVICE_TYPE))
    add(var('Error register', 0x1001, 0, U8, 'ro', 0))
    add(var('Manufacturer status register', 0x1002, 0, U32, 'ro', 0, mappable=True))
    add(container('Pre-defined error field', 0x1003,
                  [var(f'Standard error field {i}', 0x1003, i, U32, 'ro', 0) for i in range(1, 11)],
                  array=True, count_access='rw', count=0))
    add(var('COB-ID SYNC', 0x1005, 0, U32, 'rw', 0x80))
    add(var('Communication cycle period', 0x1006, 0, U32, 'rw', 0))
    add(var('Manufacturer device name', 0x1008, 0, VS, 'const', 'M006'))
    add(var('Manufacturer software version', 0x100A, 0, VS, 'const', '0.20'))
    add(var('Guard time', 0x100C, 0, U16, 'rw', 0))
    add(var('Life time factor', 0x100D, 0, U8, 'rw', 0))
    add(container('Store parameters', 0x1010, [var('Save all parameters (DRV.NVSAVE)', 0x1010, 1, U32, 'rw', 1)],
                  array=True))
    add(container('Restore default parameters', 0x1011,
                  [var('Load all parameters (DRV.NVLOAD)', 0x1011, 1, U32, 'rw', 1)], array=True))
    add(var('COB-ID EMCY', 0x1014, 0, U32, 'rw', 0x80, relative=True))
    add(container('Consumer heartbeat time', 0x1016,
                  [var('Consumer heartbeat time 1', 0x1016, 1, U32, 'rw', 0)], array=True))
    add(var('Producer heartbeat time', 0x1017, 0, U16, 'rw', 0))
    add(container('Identity object', 0x1018, [
        var('Vendor-ID', 0x1018, 1, U32, 'ro', VENDOR_ID),
        var('Product code', 0x1018, 2, U32, 'ro', PRODUCT_CODE),
        var('Revision number', 0x1018, 3, U32, 'ro', REVISION),
        var('Serial number', 0x1018, 4, U32, 'ro', 0)]))


def pdos(od: canopen.ObjectDictionary) -> None:
    """Four RPDOs (communication record sub0..2 only) and four TPDOs (sub0..5)."""
    for n in range(1, 5):
        comm, mapping = 0x1400 + n - 1, 0x1600 + n - 1
        od.add_object(container(f'RPDO{n} communication parameter', comm, [
            var('COB-ID', comm, 1, U32, 'rw', 0x100 + 0x100 * n, relative=True),
            var('Transmission type', comm, 2, U8, 'rw', 0xFF)]))
        od.add_object(mapping_record(f'RPDO{n} mapping parameter', mapping, FACTORY_RPDOS[n]))
        comm, mapping = 0x1800 + n - 1, 0x1A00 + n - 1
        od.add_object(container(f'TPDO{n} communication parameter', comm, [
            var('COB-ID', comm, 1, U32, 'rw', 0x80 + 0x100 * n, relative=True),
            var('Transmission type', comm, 2, U8, 'rw', 0xFF),
            var('Inhibit time', comm, 3, U16, 'rw', 0),
            var('Reserved', comm, 4, U8, 'const', 0),
            var('Event timer', comm, 5, U16, 'rw', 0)]))
        od.add_object(mapping_record(f'TPDO{n} mapping parameter', mapping, FACTORY_TPDOS[n]))


def manufacturer(od: canopen.ObjectDictionary) -> None:
    add = od.add_object
    for n in range(1, 5):
        index = 0x2013 + n
        add(container(f'TPDO{n} change mask', index, [
            var('Mask for PDO bytes 0..3', index, 1, U32, 'rw', 0xFFFFFFFF),
            var('Mask for PDO bytes 4..7', index, 2, U32, 'rw', 0xFFFFFFFF)]))
    add(container('Firmware version', 0x2018, [
        var('Major', 0x2018, 1, U16, 'const', 1), var('Minor', 0x2018, 2, U16, 'const', 6),
        var('Revision', 0x2018, 3, U16, 'const', 0), var('Derived revision', 0x2018, 4, U16, 'const', 0)]))
    add(container('pv scaling factor', 0x204C, [
        var('pv scaling numerator', 0x204C, 1, I32, 'rw', 1, low=-32768, high=32767),
        var('pv scaling denominator', 0x204C, 2, I32, 'rw', 1, low=-32768, high=32767)], array=True))
    add(container('ASCII channel', 0x2026, [
        var('Command', 0x2026, 1, VS, 'wo', ''), var('Response', 0x2026, 2, VS, 'ro', '')]))
    add(var('Dummy (4 bytes, for shared RPDOs)', 0x2100, 0, U32, 'rw', 0, mappable=True))
    add(container('Controlled stop (CS)', 0x3440, [
        var('CS.DEC', 0x3440, 1, U32, 'rw', 200 * COUNTS_PER_REV),
        var('CS.VTHRESH', 0x3440, 2, U32, 'rw', 0),
        var('CS.TO', 0x3440, 3, U32, 'rw', 0)]))
    add(container('PLL (FBUS)', 0x3496, [
        var('FBUS.SYNCDIST', 0x3496, 1, U32, 'rw', 320000),
        var('FBUS.SYNCACT', 0x3496, 2, U32, 'rw', 320000),
        var('FBUS.SYNCWND', 0x3496, 3, U32, 'rw', 70000),
        var('FBUS.COMPTIME', 0x3496, 4, U32, 'rw', 150)]))
    add(var('DRV.ACC', 0x3501, 0, I32, 'rw', 100 * COUNTS_PER_REV))
    add(var('DRV.DEC', 0x3522, 0, I32, 'rw', 100 * COUNTS_PER_REV))
    add(var('MT.TPOSWND', 0x35C6, 0, I32, 'rw', 1000))
    for index, name, default in ((0x36E5, 'FBUS.PARAM01 (bit rate)', 125),
                                 (0x36E6, 'FBUS.PARAM02 (PLL)', 0),
                                 (0x36E7, 'FBUS.PARAM03', 0),
                                 (0x36E8, 'FBUS.PARAM04 (SYNC supervision)', 0),
                                 (0x36E9, 'FBUS.PARAM05', 0)):
        add(var(name, index, 0, U32, 'rw', default))


def profile(od: canopen.ObjectDictionary) -> None:
    add = od.add_object
    simple = [  # index, name, type, access, default, mappable
        (0x6040, 'Controlword', U16, 'rw', 0, True),
        (0x6041, 'Statusword', U16, 'ro', 0, True),
        (0x6060, 'Modes of operation', I8, 'rw', 0, True),
        (0x6061, 'Modes of operation display', I8, 'ro', 0, True),
        (0x6063, 'Position actual value (increments)', I32, 'ro', 0, True),
        (0x6064, 'Position actual value (PL.FB)', I32, 'ro', 0, True),
        (0x6065, 'Following error window (PL.ERRFTHRESH)', U32, 'rw', 0, False),
        (0x606B, 'Velocity demand value (VL.CMD)', I32, 'ro', 0, False),
        (0x606C, 'Velocity actual value (VL.FB)', I32, 'ro', 0, True),
        (0x606D, 'Velocity window', U16, 'rw', 1000, True),
        (0x606E, 'Velocity window time', U16, 'rw', 0, True),
        (0x6071, 'Target torque', I16, 'rw', 0, True),
        (0x6072, 'Max torque', U16, 'rw', 3000, True),
        (0x6073, 'Max current', U16, 'rw', 0, False),
        (0x6077, 'Torque actual value', I16, 'ro', 0, True),
        (0x607A, 'Target position (MT.P)', I32, 'rw', 0, True),
        (0x607C, 'Home offset (HOME.P)', I32, 'rw', 0, False),
        (0x6081, 'Profile velocity (MT.V)', U32, 'rw', 10, True),
        (0x6083, 'Profile acceleration (MT.ACC)', U32, 'rw', 0, True),
        (0x6084, 'Profile deceleration (MT.DEC)', U32, 'rw', 0, True),
        (0x6098, 'Homing method (HOME.MODE, HOME.DIR)', I8, 'rw', 0, False),
        (0x609A, 'Homing acceleration (HOME.ACC)', U32, 'rw', 0, False),
        (0x60B1, 'Velocity offset (VL.BUSFF)', I32, 'rw', 0, True),
        (0x60B2, 'Torque offset', I16, 'rw', 0, True),
        (0x60F4, 'Following error actual value (PL.ERR)', I32, 'ro', 0, True),
        (0x60FD, 'Digital inputs', U32, 'ro', 0, True),
        (0x60FF, 'Target velocity (VL.CMDU)', I32, 'rw', 0, True),
        (0x6502, 'Supported drive modes', U32, 'ro', SUPPORTED_DRIVE_MODES, False),
    ]
    for index, name, data_type, access, default, mappable in simple:
        add(var(name, index, 0, data_type, access, default, mappable))
    add(container('Software position limit', 0x607D, [
        var('Software position limit 1 (SWLS.LIMIT0)', 0x607D, 1, I32, 'rw', 0),
        var('Software position limit 2 (SWLS.LIMIT1)', 0x607D, 2, I32, 'rw', 0)], array=True))
    add(container('Position encoder resolution', 0x608F, [
        var('Encoder increments', 0x608F, 1, U32, 'rw', COUNTS_PER_REV),
        var('Motor revolutions', 0x608F, 2, U32, 'rw', 1)], array=True))
    add(container('Gear ratio', 0x6091, [
        var('Motor shaft revolutions', 0x6091, 1, U32, 'rw', 1),
        var('Driving shaft revolutions', 0x6091, 2, U32, 'rw', 1)], array=True))
    add(container('Feed constant', 0x6092, [
        var('Feed (UNIT.PIN)', 0x6092, 1, U32, 'rw', 1),
        var('Shaft revolutions (UNIT.POUT)', 0x6092, 2, U32, 'rw', 1)], array=True))
    add(container('Homing speeds', 0x6099, [
        var('Speed during search for switch (HOME.V)', 0x6099, 1, U32, 'rw', COUNTS_PER_REV),
        var('Speed during search for zero (HOME.FEEDRATE)', 0x6099, 2, U32, 'rw', COUNTS_PER_REV // 8)],
        array=True))
    add(var('Interpolation sub mode select', 0x60C0, 0, I16, 'rw', 0, low=-2, high=0))
    add(container('Interpolation data record', 0x60C1, [
        var('Interpolation position (counts)', 0x60C1, 1, I32, 'rw', 0, True),
        var('Interpolation time (ms)', 0x60C1, 2, U32, 'rw', 0, True),
        var('Interpolation velocity (counts/s)', 0x60C1, 3, I32, 'rw', 0, True)]))
    add(container('Interpolation time period (FBUS.SAMPLEPERIOD)', 0x60C2, [
        var('Interpolation time units', 0x60C2, 1, U8, 'rw', 1),
        var('Interpolation time index', 0x60C2, 2, I8, 'rw', -3)]))
    add(container('Interpolation data configuration', 0x60C4, [
        var('Maximum buffer size', 0x60C4, 1, U32, 'ro', 10),
        var('Actual buffer size (free places)', 0x60C4, 2, U32, 'ro', 9, True, low=0, high=9),
        var('Buffer organization', 0x60C4, 3, U8, 'rw', 0),
        var('Buffer position', 0x60C4, 4, U16, 'rw', 0),
        var('Size of data record', 0x60C4, 5, U8, 'wo', 1, low=1, high=254),
        var('Buffer clear', 0x60C4, 6, U8, 'wo', 0)]))
    add(container('Digital outputs', 0x60FE, [
        var('Physical outputs', 0x60FE, 1, U32, 'rw', 0, True),
        var('Bit mask', 0x60FE, 2, U32, 'rw', 0)], array=True))


def check(reread: canopen.ObjectDictionary) -> None:
    assert variable(reread, 0x1014).default == 0x85, 'COB-ID EMCY must be relative to the node id'
    assert variable(reread, 0x1401, 1).default == 0x305, 'RPDO COB-IDs must be relative to the node id'
    assert variable(reread, 0x60C2, 2).default == -3 and variable(reread, 0x60C0).min == -2
    assert 3 not in members(reread, 0x1400).subindices, 'AKD RPDO communication records have sub0..2 only'


DEVICE = Device('Kollmorgen (Danaher Motion)', VENDOR_ID,
                'AKD servo drive (CANopen), drive_bridge model of manual rev. F', PRODUCT_CODE, REVISION,
                (125, 250, 500, 1000))
FILES = (EdsFile(family_data('akd', 'akd.eds'), DEVICE, (communication, pdos, manufacturer, profile), check),)

if __name__ == '__main__':
    main(FILES)
