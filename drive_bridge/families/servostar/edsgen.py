"""Write the EDS of the Kollmorgen SERVOSTAR 400/600 family: drive_bridge/families/servostar/data/servostar.eds.

No EDS of the drive is at hand, so this file is built from the German manual "CANopen
SERVOSTAR 400/600, Kommunikationsprofil" (edition 12/2009, firmware >= 6.57) as summarised
in shared/drives/servostar-400-600.md (section numbers in brackets are that document's,
the manual's own in the document): the communication objects of its dictionary [8.1], the
PDO machinery [2.5-2.8], the manufacturer objects the bridge, the simulator
(drive_bridge/sim/servostar/) or the manual's worked examples touch [8.2], the object-
channel entries the simulator implements [8.3, 8.4], and the profile objects [8.5].

Run it again after changing the object list::

    .venv/bin/python -m drive_bridge.families.servostar.edsgen

Readings (the manual is silent, garbled or self-contradictory; each choice is the
simulator's too):

Communication area
- 0x1000 = 0x00020192 (servo drive, profile 402, manufacturer-specific mode bits) [1.1 D].
- 0x1002 manufacturer status register: UNSIGNED32 ro, PDO-mappable (TPDO 23 maps it with 32
  bits); the object text's UNSIGNED8 is not followed [3.5].
- 0x1003: ARRAY with ONE entry ("only the last error is kept"): sub 0 UNSIGNED8 rw (writing 0
  deletes the entry, does not acknowledge the error; the text's "sub 02" is read as sub 0),
  sub 1 UNSIGNED32 ro (the object text's ro, not the table's rw) [3.4].
- 0x1004 (number of PDOs, compatibility entry): a RECORD whose sub 0 is UNSIGNED32 ro
  0x00020002 as printed, sub 1 (synchronous) 0, sub 2 (asynchronous) 0x00020002 [8.1]. It
  still reports 2+2 although the drive has 4+4 channels [2.5].
- 0x1005 COB-ID SYNC default 0x80000080, rw (the text's rw, not the table's ro) [2.9].
- 0x1006 / 0x1007 in us, default 0. 0x100B node id: ro, $NODEID.
- 0x100C guard time (ms, UNSIGNED16) rw (the table's rw, not the text's ro; a master must
  set it), 0x100D life time factor UNSIGNED8 rw, both default 0 = life guarding off;
  0x100E COB-ID node guarding rw $NODEID+0x700 [2.11]. NO 0x1016 / 0x1017 (no heartbeat),
  no 0x1011, 0x1029, 0x1200 [2.12].
- 0x100F number of SDOs: UNSIGNED32 ro 1 ("Din" read as 1) [2.4].
- 0x1010: sub 0 = 2; sub 1 "save all parameters" is "reserved" (rw, reads 0 = the device
  does not save on command through it); sub 2 "save communication parameters" rw, reads 1,
  takes the signature "save" (0x65766173) and works only with DRVCNFG bit 3 [2.5, 8.1].
- 0x1012 / 0x1013 are "in preparation" and kept (rw, 0x100 / 0): TIME is not supported.
- 0x1008 "SD06" (a 6 A drive), 0x100A "6.57" (the firmware this manual edition is valid
  from), 0x1018:1 0x6A, :2 product code 6 (the output-stage current rating, A), :3 revision
  0x02910400 (firmware 657 in the high word, CANopen 4.00 in the low word), :4 0 [1.1].
- RPDO communication 0x1400-0x1403 and TPDO communication 0x1800-0x1803: sub 0 = 4 (ro),
  sub 1 COB-ID, sub 2 transmission type, sub 3 inhibit time (UNSIGNED16; unit not printed,
  read as 100 us; "not meaningful" for RPDOs), sub 4 CMS priority group (UNSIGNED8 rw,
  compatibility entry). NO sub 5 (event timer) anywhere [2.6, 2.7]. COB-IDs are the CiA 301
  predefined ids for all four channels (valid; channels 3/4 have an empty PDO by default).
  Default transmission type 255 for every channel (RPDO "evaluated immediately", TPDO "sent
  event-driven") [2.5 B].
- Mapping 0x1600-0x1603 / 0x1A00-0x1A03: sub 0 UNSIGNED8 and subs 1-8 UNSIGNED32, written
  rw here because they are writable while a free PDO 37-40 is selected in the channel; while
  a library PDO is selected they are read-only (the simulator answers 0x06010002; an EDS
  cannot express that condition) [2.5, 2.8]. Defaults = the power-on configuration:
  RPDO 1 = PDO 1 (6040h), RPDO 2 = PDO 21 (ASCII 3100h:01-08, 8 bits each),
  TPDO 1 = PDO 1 (6041h), TPDO 2 = PDO 21 (ASCII 3102h:01-08); channels 3/4 empty [2.5].
- Granularity 8: mapping entries are whole bytes; 24-bit entries exist (2070h:01/02).
- Bit rates 10, 20, 50, 100, 125, 250, 333, 500 (default), 666, 800, 1000 kbit/s [1.2]; the
  EDS keys only know the CiA set (10, 20, 50, 125, 250, 500, 800, 1000), so 100, 333 and 666
  are not expressible there.

Manufacturer area
- 0x2600-0x2603 (RPDO select) / 0x2A00-0x2A03 (TPDO select): UNSIGNED8 rw, not mappable
  (the text's UNSIGNED8, not the table's INTEGER8: the values go up to 40 and the range is
  printed 0-255). Defaults 1, 21, 0, 0 (the power-on PDOs; 0 = no PDO, empty mapping). The
  printed "default 0" of 2A00h is read as channels 3/4 [2.5-2.7].
- 0x2014-0x2017 TPDO change masks: sub 1 bytes 0-3, sub 2 bytes 4-7, UNSIGNED32 rw,
  0xFFFFFFFF [2.5].
- 0x2020 position controller: sub 3 PEMAX (max following error, user units, default
  0x40000; 0 = not monitored). PGEARO/PGEARI (subs 8/9) default 1/1 as printed, so user units
  of 2020h/2070h:06-08 are increments by default; 0x6093 keeps its own printed defaults
  (2^20 / 10000) - the manual's "6093h mirrors PGEARO/PGEARI" contradicts the two default
  columns, so the two are separate objects here [6.3, 7.1].
- 0x2022 motion-task record subs 1-0x0F: sub 4 = the trajectory (mode 0xFA) position
  setpoint, INTEGER32 rw mappable (RPDO 33 maps it twice). Mappable: subs 1-5 and 0x0F (the
  document's reading of the garbled "rww" marks); sub 2 INTEGER16, sub 3 UNSIGNED16 (the OD
  table's types); sub 0x0C OCOPY UNSIGNED32 wo (two UNSIGNED16 words); sub 0x0D VMUL default
  1 [6.4].
- 0x2024 homing/jog record, none mappable; ramps in ms, default 10 [6.1].
- 0x2031 write-only dummies and 0x2071 read-only dummies, subs 1-4 = 8/16/24/32 bits,
  mappable (the text's "2027h" header is a typo for 2071h) [2.8].
- 0x2060 digital speed/current setpoint INTEGER32 rw mappable (speed: 1 bit = 1875/262144
  rpm; current: 3280 = peak current); 0x2061 current limit UNSIGNED16 wo mappable [6.7].
- 0x2070 actual values: sub 1 position within 16 revolutions as UNSIGNED24 (the OD table's
  24 bits; the text's U32 would not decode from the 24-bit PDO field), sub 2 speed as
  INTEGER24 (signed: the drive turns both ways) in 1875/262144 rpm, sub 3 incremental
  position INTEGER32 in 2^20/rev (the OD's "depends on PRBASE"), sub 0x11 extended status
  for TPDO 33, sub 0x13 internal position setpoint (TPDO 41), sub 0x16 ERRCODE; types and
  mappability of the other subs per [8.2].
- 0x2080 status bytes (DRVSTAT/TRJSTAT byte-wise, UNSIGNED8 ro mappable) [8.2]; 0x2086 position
  trigger word UNSIGNED16 ro mappable (TPDO 34) [2.7].
- 0x2721 PDO 33 half select: UNSIGNED8 rw (not the OD's INTEGER8), not mappable, default 0,
  range 0-4 as printed; 0 = bytes 0-3, 1 or 4 = bytes 4-7 (the text's 0/1 and the example's
  04h; the simulator's option decides whether 1, 4 or both pick the upper half) [5.1].
- 0x3100 ASCII receive characters and 0x3102 ASCII send characters: ARRAYs of 8 UNSIGNED8
  (one character each), mappable, because the PDO tables map 3100h:01-08 (RPDO 21) and
  3102h:01-08 (TPDO 21) with 8 bits each; the OD table's single "3100h Visible String" cannot
  be mapped that way. 3100h rw, 3102h ro [2.6, 2.7, 12].

Object channel (0x3500+): each object is a RECORD of 8 subs - 1 value (the ASCII command's
type; commands without data are UNSIGNED32, written with any value to execute), 2 lower
limit, 3 upper limit, 4 default, 5 format (UNSIGNED8), 6 control flags (UNSIGNED32:
0x00010000 save + reset needed, 0x00020000 in EEPROM), 7/8 reserved; none mappable [8.3].
Only the objects the simulator implements are listed: MAXSDO 3500h, ACC 3501h, ADDR 3505h,
AENA 3506h, CBAUD 3515h, CLRFAULT 3518h, CLRWARN 351Bh, DEC 3522h, DECSTOP 3525h (the
emergency ramp, ms from VLIM to 0; default 10 ms: not printed), DRVSTAT 352Dh, OPMODE
35B4h, PEMAX 35C7h (= 2020h:03), PRBASE 35D1h (16 or 20 bits/rev, default 20, "Disabled
Reset"), PTBASE 35D5h (250 us units, default 4 = 1 ms, matching 60C2h's 1 x 10^-3 s; saved
and cold-started to take effect), SAVE 35EBh, VLIM 3622h (rpm, default 3000: not printed),
COLDSTART 3632h ("Disabled"), MDRV 3639h, DRVCNFG 3672h (INTEGER32, default 0: not printed).

Profile area [8.5]
- 0x6040 controlword UNSIGNED16 rw mappable (the text's rw and type, not the table's wo
  INTEGER16: masters read it back); 0x6041 statusword UNSIGNED16 ro mappable.
- 0x6060 modes of operation INTEGER8 **wo** mappable (an upload aborts 0x06010001);
  0x6061 display INTEGER8 ro mappable (the table's ro, not the text's wo).
- 0x605A quick-stop option code INTEGER16 rw, values undocumented: default 6 (brake on the
  quick-stop ramp and stay in Quick Stop Active with the output stage enabled, which is what the
  manual describes: "stopped with the emergency ramp; output stage enabled").
- 0x6063 (increments, 2^PRBASE/rev), 0x6064 (user units via 6093h), 0x606C (velocity units,
  6094h; 0/0 = increments per 250 us), 0x6077 (per mille of rated torque): ro mappable (the
  table's ro, not the text's rw).
- 0x607A, 0x607C, 0x6081 (default 10), 0x6083 / 0x6084 (ramp TIMES in ms, UNSIGNED32 with
  range 0-32767, default 0), 0x6086 (0 linear, 1 sin^2), 0x6098, 0x6099 (subs 1/2, 2^20 and
  2^20/8: the second is not printed), 0x609A, 0x60C2 (sub 1 UNSIGNED8 default 1, sub 2
  INTEGER8 default -3 - the text's type, not the table's INTEGER16; only whole ms),
  0x60FF: rw mappable.
- 0x607B modulo range (subs 1/2, INTEGER32 rw, -2^31 / 2^31-1), 0x6093 (2^20 / 10000),
  0x6094 (0 / 0) rw not mappable; 0x6097 acceleration factor ro fixed 1/1 (the text's ro and
  value, not the printed default 0).
- 0x6089-0x608E notation/dimension indices: present, rw, not mappable, default 0, "not
  supported" (stored, no effect).
- Absent as the manual says: 0x6062, 0x6065-0x606B, 0x606D-0x6076, 0x6078-0x6080, 0x6085
  (listed in the pp chapter only), 0x60C0/0x60C1 (no interpolated position mode), 0x60F4,
  0x60FA, 0x60FC, 0x6502 [8.6].

Left out although in the manual (nothing simulated behind them): 0x2026, 0x2030, 0x2050-
0x2053, 0x2081-0x2085, 0x2087, 0x2090, and all object-channel entries but the ones listed above.
"""
from __future__ import annotations

import canopen
from canopen.objectdictionary import ODRecord, datatypes as dt

from drive_bridge.families.edswriter import Device, EdsFile, container, main, mapping_record, members, var, variable
from drive_bridge.resources import family_data

VENDOR_ID = 0x0000006A
PRODUCT_CODE = 6  # output-stage current rating (A): SD06
REVISION = (657 << 16) | 0x0400  # firmware 6.57, CANopen 4.00
DEVICE_TYPE = 0x00020192
COUNTS_PER_REV = 2 ** 20

I8, I16, I24, I32 = dt.INTEGER8, dt.INTEGER16, dt.INTEGER24, dt.INTEGER32
U8, U16, U24, U32 = dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED24, dt.UNSIGNED32
VS = dt.VISIBLE_STRING

ASCII_RX = [0x31000008 | (k << 8) for k in range(1, 9)]
ASCII_TX = [0x31020008 | (k << 8) for k in range(1, 9)]
# power-on PDO configuration per channel: (selected library PDO, mapping entries)
POWER_ON_RPDOS = {1: (1, [0x60400010]), 2: (21, ASCII_RX), 3: (0, []), 4: (0, [])}
POWER_ON_TPDOS = {1: (1, [0x60410010]), 2: (21, ASCII_TX), 3: (0, []), 4: (0, [])}

# object channel entries: index -> (ASCII name, value type, access, default, low, high, control flags)
SAVE_RESET, IN_EEPROM = 0x00010000, 0x00020000
OBJECT_CHANNEL = {
    0x3500: ('MAXSDO', U32, 'ro', 0, None, None, 0),
    0x3501: ('ACC', I16, 'rw', 10, 1, 32767, IN_EEPROM),
    0x3505: ('ADDR', U8, 'rw', 1, 0, 127, IN_EEPROM),
    0x3506: ('AENA', I8, 'rw', 1, 0, 1, IN_EEPROM),
    0x3515: ('CBAUD', I16, 'rw', 500, 10, 1000, SAVE_RESET | IN_EEPROM),
    0x3518: ('CLRFAULT', U32, 'rw', 0, None, None, 0),
    0x351B: ('CLRWARN', U8, 'rw', 0, 0, 1, SAVE_RESET | IN_EEPROM),
    0x3522: ('DEC', I16, 'rw', 10, 1, 32767, IN_EEPROM),
    0x3525: ('DECSTOP', I16, 'rw', 10, 1, 32767, IN_EEPROM),
    0x352D: ('DRVSTAT', I32, 'ro', 0, None, None, 0),
    0x35B4: ('OPMODE', I8, 'rw', 8, 0, 8, IN_EEPROM),
    0x35C7: ('PEMAX', I32, 'rw', 0x40000, 0, None, IN_EEPROM),
    0x35D1: ('PRBASE', I8, 'rw', 20, 16, 20, SAVE_RESET | IN_EEPROM),
    0x35D5: ('PTBASE', I8, 'rw', 4, 4, 127, SAVE_RESET | IN_EEPROM),
    0x35EB: ('SAVE', U32, 'rw', 0, None, None, 0),
    0x3622: ('VLIM', I32, 'rw', 3000, 0, None, IN_EEPROM),
    0x3632: ('COLDSTART', U32, 'rw', 0, None, None, 0),
    0x3639: ('MDRV', I8, 'rw', 0, 0, 1, IN_EEPROM),
    0x3672: ('DRVCNFG', I32, 'rw', 0, None, None, IN_EEPROM),
}
FORMAT_CODES = {None: 0, I8: 3, U8: 4, I16: 5, U16: 6, I32: 7, U32: 8}


def communication(od: canopen.ObjectDictionary) -> None:
    add = od.add_object
    add(var('Device type', 0x1000, 0, U32, 'ro', DEVICE_TYPE))
    add(var('Error register', 0x1001, 0, U8, 'ro', 0))
    add(var('Manufacturer status register (DRVSTAT)', 0x1002, 0, U32, 'ro', 0, mappable=True))
    add(container('Pre-defined error field (last error only)', 0x1003,
                  [var('Last reported error', 0x1003, 1, U32, 'ro', 0)],
                  array=True, count_access='rw', count=0))
    pdo_count = ODRecord('Number of PDOs supported (compatibility)', 0x1004)
    pdo_count.add_member(var('Number of PDOs supported', 0x1004, 0, U32, 'ro', 0x00020002))
    pdo_count.add_member(var('Number of synchronous PDOs', 0x1004, 1, U32, 'ro', 0))
    pdo_count.add_member(var('Number of asynchronous PDOs', 0x1004, 2, U32, 'ro', 0x00020002))
    add(pdo_count)
    add(var('COB-ID SYNC', 0x1005, 0, U32, 'rw', 0x80000080))
    add(var('Communication cycle period', 0x1006, 0, U32, 'rw', 0))
    add(var('Synchronous window length', 0x1007, 0, U32, 'rw', 0))
    add(var('Manufacturer device name', 0x1008, 0, VS, 'const', 'SD06'))
    add(var('Manufacturer software version', 0x100A, 0, VS, 'const', '6.57'))
    add(var('Node-ID (ADDR)', 0x100B, 0, U32, 'ro', 0, relative=True))
    add(var('Guard time', 0x100C, 0, U16, 'rw', 0))
    add(var('Life time factor', 0x100D, 0, U8, 'rw', 0))
    add(var('COB-ID node guarding', 0x100E, 0, U32, 'rw', 0x700, relative=True))
    add(var('Number of supported SDOs', 0x100F, 0, U32, 'ro', 1))
    add(container('Store parameters', 0x1010, [
        var('Save all parameters (reserved)', 0x1010, 1, U32, 'rw', 0),
        var('Save communication parameters (DRVCNFG bit 3)', 0x1010, 2, U32, 'rw', 1)], array=True))
    add(var('COB-ID time stamp (in preparation)', 0x1012, 0, U32, 'rw', 0x100))
    add(var('High resolution time stamp (in preparation)', 0x1013, 0, U32, 'rw', 0))
    add(var('COB-ID EMCY', 0x1014, 0, U32, 'rw', 0x80, relative=True))
    add(container('Identity object', 0x1018, [
        var('Vendor-ID', 0x1018, 1, U32, 'ro', VENDOR_ID),
        var('Product code (current rating)', 0x1018, 2, U32, 'ro', PRODUCT_CODE),
        var('Revision number', 0x1018, 3, U32, 'ro', REVISION),
        var('Serial number (SERIALNO)', 0x1018, 4, U32, 'ro', 0)]))


def comm_record(name: str, index: int, cob_base: int) -> ODRecord:
    return container(name, index, [  # type: ignore[return-value]
        var('COB-ID', index, 1, U32, 'rw', cob_base, relative=True),
        var('Transmission type', index, 2, U8, 'rw', 0xFF),
        var('Inhibit time', index, 3, U16, 'rw', 0),
        var('CMS priority group (compatibility)', index, 4, U8, 'rw', 0)])


def pdos(od: canopen.ObjectDictionary) -> None:
    """Four channels per direction: communication (sub 0..4, no event timer), mapping
    (writable only for the free PDOs), and the library selection objects."""
    for n in range(1, 5):
        selected, entries = POWER_ON_RPDOS[n]
        od.add_object(comm_record(f'RPDO{n} communication parameter', 0x1400 + n - 1, 0x100 + 0x100 * n))
        od.add_object(mapping_record(f'RPDO{n} mapping parameter (writable for PDO 37-40 only)',
                                     0x1600 + n - 1, entries))
        od.add_object(var(f'RPDO{n} select (library PDO number)', 0x2600 + n - 1, 0, U8, 'rw', selected,
                          low=0, high=255))
        selected, entries = POWER_ON_TPDOS[n]
        od.add_object(comm_record(f'TPDO{n} communication parameter', 0x1800 + n - 1, 0x80 + 0x100 * n))
        od.add_object(mapping_record(f'TPDO{n} mapping parameter (writable for PDO 37-40 only)',
                                     0x1A00 + n - 1, entries))
        od.add_object(var(f'TPDO{n} select (library PDO number)', 0x2A00 + n - 1, 0, U8, 'rw', selected,
                          low=0, high=255))


def manufacturer(od: canopen.ObjectDictionary) -> None:
    add = od.add_object
    for n in range(1, 5):
        index = 0x2013 + n
        add(container(f'TPDO{n} change mask', index, [
            var('Mask for PDO bytes 0..3', index, 1, U32, 'rw', 0xFFFFFFFF),
            var('Mask for PDO bytes 4..7', index, 2, U32, 'rw', 0xFFFFFFFF)]))
    add(container('Position controller', 0x2020, [
        var('Axis type (POSCNFG)', 0x2020, 1, U8, 'rw', 0, low=0, high=1),
        var('In-position window (PEINPOS)', 0x2020, 2, I32, 'rw', 0x4000),
        var('Max following error (PEMAX)', 0x2020, 3, I32, 'rw', 0x40000),
        var('Position register 1 (SWE1)', 0x2020, 4, I32, 'rw', 0),
        var('Position register 2 (SWE2)', 0x2020, 5, I32, 'rw', 0),
        var('Position register 3 (SWE3)', 0x2020, 6, I32, 'rw', 0),
        var('Position register 4 (SWE4)', 0x2020, 7, I32, 'rw', 0),
        var('Resolution denominator (PGEARO)', 0x2020, 8, U32, 'rw', 1),
        var('Resolution numerator (PGEARI)', 0x2020, 9, U32, 'rw', 1),
        var('Counting direction (DIR)', 0x2020, 10, U8, 'rw', 1, low=0, high=1)]))
    add(container('Motion task / positioning data', 0x2022, [
        var('Position (OP)', 0x2022, 1, I32, 'rw', 0, True),
        var('Weighted speed (OV)', 0x2022, 2, I16, 'rw', 0, True),
        var('Motion task type (OC)', 0x2022, 3, U16, 'rw', 0, True),
        var('Trajectory position setpoint (mode 0xFA)', 0x2022, 4, I32, 'rw', 0, True),
        var('Motion task number', 0x2022, 5, U16, 'rw', 0, True, low=0, high=255),
        var('Acceleration time (O_ACC1)', 0x2022, 6, U16, 'rw', 10),
        var('Deceleration time (O_DEC1)', 0x2022, 7, U16, 'rw', 10),
        var('Jerk limit acceleration (O_ACC2)', 0x2022, 8, U16, 'rw', 0),
        var('Jerk limit deceleration (O_DEC2)', 0x2022, 9, U16, 'rw', 0),
        var('Next task number (O_FN)', 0x2022, 10, U16, 'rw', 0),
        var('Start delay for next task (O_FT)', 0x2022, 11, U16, 'rw', 0),
        var('Copy motion task (OCOPY)', 0x2022, 12, U32, 'wo', 0),
        var('Speed weighting factor (VMUL)', 0x2022, 13, U16, 'rw', 1),
        var('Speed of direct task 0', 0x2022, 14, I32, 'rw', 0),
        var('Setpoint position CAN master/slave', 0x2022, 15, I32, 'rw', 0, True)]))
    add(container('Homing and jog set-up', 0x2024, [
        var('Homing type (NREF)', 0x2024, 1, U8, 'rw', 0, low=0, high=6),
        var('Homing direction (DREF)', 0x2024, 2, U8, 'rw', 0, low=0, high=2),
        var('Homing speed (VREF)', 0x2024, 3, I32, 'rw', 0),
        var('Acceleration ramp jog/homing (ACCR)', 0x2024, 4, U16, 'rw', 10, low=1, high=32767),
        var('Deceleration ramp jog/homing (DECR)', 0x2024, 5, U16, 'rw', 10, low=1, high=32767),
        var('Reference offset (ROFFS)', 0x2024, 6, I32, 'rw', 0),
        var('Jog speed (VJOG)', 0x2024, 7, I32, 'rw', 0)]))
    add(container('Dummy for RPDOs (write only)', 0x2031, [
        var('Dummy 8 bit', 0x2031, 1, U8, 'wo', 0, True), var('Dummy 16 bit', 0x2031, 2, U16, 'wo', 0, True),
        var('Dummy 24 bit', 0x2031, 3, U24, 'wo', 0, True), var('Dummy 32 bit', 0x2031, 4, U32, 'wo', 0, True)]))
    add(var('Digital speed or current setpoint', 0x2060, 0, I32, 'rw', 0, True))
    add(var('Current limit (DPRILIMIT)', 0x2061, 0, U16, 'wo', 0, True, low=0, high=3280))
    add(container('Actual values', 0x2070, [
        var('Actual position, 20 bit/rev within 16 rev (PRD)', 0x2070, 1, U24, 'ro', 0, True),
        var('Actual speed (1875/262144 rpm)', 0x2070, 2, I24, 'ro', 0, True),
        var('Incremental actual position (2^20/rev)', 0x2070, 3, I32, 'ro', 0, True),
        var('16-bit position latch', 0x2070, 4, I16, 'ro', 0, True),
        var('32-bit position latch', 0x2070, 5, I32, 'ro', 0, True),
        var('SI actual position (PFB)', 0x2070, 6, I32, 'ro', 0, True),
        var('SI actual speed (PV)', 0x2070, 7, I32, 'ro', 0),
        var('Following error (PE)', 0x2070, 8, I32, 'ro', 0),
        var('RMS current, mA (I)', 0x2070, 9, U32, 'ro', 0),
        var('Speed, rpm (V)', 0x2070, 10, I32, 'ro', 0),
        var('Heat-sink temperature (TEMPH)', 0x2070, 11, I32, 'ro', 35),
        var('Internal temperature (TEMPE)', 0x2070, 12, I32, 'ro', 30),
        var('DC-link voltage (VBUS)', 0x2070, 13, I32, 'ro', 560),
        var('Ballast power (PBAL)', 0x2070, 14, I32, 'ro', 0),
        var('I2t load (I2T)', 0x2070, 15, I32, 'ro', 0),
        var('Operating time, min (TRUN)', 0x2070, 16, I32, 'ro', 0),
        var('Extended status for TPDO 33', 0x2070, 17, U32, 'ro', 0, True),
        var('Absolute encoder position (PFB0)', 0x2070, 18, I32, 'ro', 0, True),
        var('Internal position setpoint', 0x2070, 19, I32, 'ro', 0, True),
        var('Analog input 1 (ANIN1)', 0x2070, 20, I16, 'ro', 0, True),
        var('Analog input 2 (ANIN2)', 0x2070, 21, I16, 'ro', 0, True),
        var('Fault register F01-F32 (ERRCODE)', 0x2070, 22, U32, 'ro', 0, True),
        var('Internal speed setpoint', 0x2070, 23, I32, 'ro', 0, True),
        var('Master speed (electronic gearing)', 0x2070, 24, U32, 'ro', 0, True),
        var('Gearing control variable', 0x2070, 25, I8, 'ro', 0, True)]))
    add(container('Dummy for TPDOs (read only)', 0x2071, [
        var('Dummy 8 bit', 0x2071, 1, U8, 'ro', 0, True), var('Dummy 16 bit', 0x2071, 2, U16, 'ro', 0, True),
        var('Dummy 24 bit', 0x2071, 3, U24, 'ro', 0, True), var('Dummy 32 bit', 0x2071, 4, U32, 'ro', 0, True)]))
    names = ['Status info input/output/latch', 'Collective info warning/error'] + \
        [f'DRVSTAT byte {k}' for k in range(4)] + [f'TRJSTAT byte {k}' for k in range(4)]
    add(container('Status bytes', 0x2080, [var(name, 0x2080, k, U8, 'ro', 0, True)
                                           for k, name in enumerate(names, start=1)]))
    add(var('Position trigger word (POSRSTAT, TPDO 34)', 0x2086, 0, U16, 'ro', 0, True))
    add(var('PDO 33 data select (half)', 0x2721, 0, U8, 'rw', 0, low=0, high=4))
    add(container('ASCII characters receive (PDO 21)', 0x3100,
                  [var(f'Character {k}', 0x3100, k, U8, 'rw', 0, True) for k in range(1, 9)], array=True))
    add(container('ASCII characters send (PDO 21)', 0x3102,
                  [var(f'Character {k}', 0x3102, k, U8, 'ro', 0, True) for k in range(1, 9)], array=True))
    for index, (name, data_type, access, default, low, high, flags) in OBJECT_CHANNEL.items():
        add(channel_object(index, name, data_type, access, default, low, high, flags))


def channel_object(index: int, name: str, data_type: int, access: str, default: int,
                   low: int | None, high: int | None, flags: int) -> ODRecord:
    command = name in ('CLRFAULT', 'SAVE', 'COLDSTART', 'MAXSDO')
    fmt = 0 if command else FORMAT_CODES.get(data_type, 7)
    members = [
        var(f'{name} value', index, 1, data_type, access, default, low=low, high=high),
        var(f'{name} lower limit', index, 2, data_type, 'ro', low or 0),
        var(f'{name} upper limit', index, 3, data_type, 'ro', 0 if high is None else high),
        var(f'{name} default', index, 4, data_type, 'ro', default),
        var(f'{name} format', index, 5, U8, 'ro', fmt),
        var(f'{name} control flags', index, 6, U32, 'ro', flags),
        var('Reserved', index, 7, U32, 'ro', 0),
        var('Reserved', index, 8, U32, 'ro', 0)]
    return container(f'{name} (object channel)', index, members)  # type: ignore[return-value]


def profile(od: canopen.ObjectDictionary) -> None:
    add = od.add_object
    simple = [  # index, name, type, access, default, mappable, low, high
        (0x6040, 'Controlword', U16, 'rw', 0, True, None, None),
        (0x6041, 'Statusword', U16, 'ro', 0, True, None, None),
        (0x605A, 'Quick stop option code', I16, 'rw', 6, False, None, None),
        (0x6060, 'Modes of operation (write only)', I8, 'wo', 0, True, None, None),
        (0x6061, 'Modes of operation display', I8, 'ro', 0, True, None, None),
        (0x6063, 'Position actual value (increments)', I32, 'ro', 0, True, None, None),
        (0x6064, 'Position actual value (user units)', I32, 'ro', 0, True, None, None),
        (0x606C, 'Velocity actual value', I32, 'ro', 0, True, None, None),
        (0x6077, 'Torque actual value (per mille)', I16, 'ro', 0, True, None, None),
        (0x607A, 'Target position', I32, 'rw', 0, True, None, None),
        (0x607C, 'Home offset', I32, 'rw', 0, True, None, None),
        (0x6081, 'Profile velocity', U32, 'rw', 10, True, None, None),
        (0x6083, 'Profile acceleration (ramp time, ms)', U32, 'rw', 0, True, 0, 32767),
        (0x6084, 'Profile deceleration (ramp time, ms)', U32, 'rw', 0, True, 0, 32767),
        (0x6086, 'Motion profile type', I16, 'rw', 0, True, 0, 1),
        (0x6089, 'Position notation index (not supported)', I8, 'rw', 0, False, None, None),
        (0x608A, 'Position dimension index (not supported)', U8, 'rw', 0, False, None, None),
        (0x608B, 'Velocity notation index (not supported)', I8, 'rw', 0, False, None, None),
        (0x608C, 'Velocity dimension index (not supported)', U8, 'rw', 0, False, None, None),
        (0x608D, 'Acceleration notation index (not supported)', I8, 'rw', 0, False, None, None),
        (0x608E, 'Acceleration dimension index (not supported)', U8, 'rw', 0, False, None, None),
        (0x6098, 'Homing method', I8, 'rw', 0, True, None, None),
        (0x609A, 'Homing acceleration', U32, 'rw', 0, True, None, None),
        (0x60FF, 'Target velocity', I32, 'rw', 0, True, None, None),
    ]
    for index, name, data_type, access, default, mappable, low, high in simple:
        add(var(name, index, 0, data_type, access, default, mappable, low=low, high=high))
    add(container('Position range limit (modulo)', 0x607B, [
        var('Min position range limit (SRND)', 0x607B, 1, I32, 'rw', -2 ** 31),
        var('Max position range limit (ERND)', 0x607B, 2, I32, 'rw', 2 ** 31 - 1)], array=True))
    add(container('Position factor', 0x6093, [
        var('Numerator (PGEARO)', 0x6093, 1, U32, 'rw', COUNTS_PER_REV),
        var('Feed constant (PGEARI)', 0x6093, 2, U32, 'rw', 10000)], array=True))
    add(container('Velocity encoder factor', 0x6094, [
        var('Numerator (increments)', 0x6094, 1, U32, 'rw', 0),
        var('Divisor (seconds)', 0x6094, 2, U32, 'rw', 0)], array=True))
    add(container('Acceleration factor (fixed)', 0x6097, [
        var('Numerator', 0x6097, 1, U32, 'ro', 1), var('Divisor', 0x6097, 2, U32, 'ro', 1)], array=True))
    add(container('Homing speeds', 0x6099, [
        var('Speed during search for switch', 0x6099, 1, U32, 'rw', COUNTS_PER_REV, True),
        var('Speed during search for zero', 0x6099, 2, U32, 'rw', COUNTS_PER_REV // 8, True)], array=True))
    add(container('Interpolation time period (PTBASE)', 0x60C2, [
        var('Interpolation time units', 0x60C2, 1, U8, 'rw', 1, True),
        var('Interpolation time index', 0x60C2, 2, I8, 'rw', -3, True)]))


def check(reread: canopen.ObjectDictionary) -> None:
    assert variable(reread, 0x1014).default == 0x85 and variable(reread, 0x100E).default == 0x705
    assert variable(reread, 0x1401, 1).default == 0x305, 'RPDO COB-IDs must be relative to the node id'
    assert 5 not in members(reread, 0x1800).subindices, 'no event timer on the SERVOSTAR'
    assert 0x1016 not in reread and 0x1017 not in reread, 'no heartbeat on the SERVOSTAR'
    assert variable(reread, 0x6060).access_type == 'wo'
    assert variable(reread, 0x60C2, 2).default == -3 and variable(reread, 0x607B, 1).default == -2 ** 31
    assert variable(reread, 0x1A01, 0).default == 8 and variable(reread, 0x1A01, 1).default == 0x31020108


DEVICE = Device('Kollmorgen (Danaher Motion)', VENDOR_ID,
                'SERVOSTAR 400/600 (CANopen), drive_bridge model of the 12/2009 manual', PRODUCT_CODE, REVISION,
                (10, 20, 50, 125, 250, 500, 800, 1000),
                simple_boot_up_slave=False)  # boot-up is an EMCY, not the 0x700 frame
FILES = (EdsFile(family_data('servostar', 'servostar.eds'), DEVICE,
                 (communication, pdos, manufacturer, profile), check),)

if __name__ == '__main__':
    main(FILES)
