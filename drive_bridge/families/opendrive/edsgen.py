"""Write the EDS of the OPEN drive family (probably TDE MACNO): drive_bridge/families/opendrive/data/opendrive.eds.

No EDS of the drive is published that we know of, so this file is built from the drive's
CANopen appendix ("Allegato CAN BUS", Italian) as summarised in shared/drives/opendrive.md
(numbers in brackets are that document's sections): the communication objects of its
object list [2.7] and every manufacturer object 0x2000-0x2026 of [3.1], with the data
type, access and PDO-mappability the appendix gives. CiA DS301 only: no CiA 402 object.

Run it again after changing the object list::

    .venv/bin/python -m drive_bridge.families.opendrive.edsgen

Readings (the appendix is silent or ambiguous; each choice is the simulator's too):

- 0x1000 device type = 0 and 0x1018 vendor id / product code / revision / serial = 0: the
  appendix lists both objects without a value [1]. 0x1008 "OPEN drive" (the product line of
  the title); 0x1009 / 0x100A "unknown" (no value given).
- No 0x1016 / 0x1017 (heartbeat is absent from the object list [2.1]), no 0x1007, 0x1012,
  0x1013, 0x1020, 0x1029, no SDO client 0x1280, nothing at 0x6000+ [2.7].
- 0x1003 pre-defined error field: ARRAY of 32 UNSIGNED32 [2.6]; every sub-index, sub 0
  included, is ro as the object list says (CiA 301 would let a master clear it by writing
  sub 0 = 0; the appendix does not say whether it can: here it cannot). Entry =
  alarm word << 16 | error code, newest at sub 1.
- 0x1005 COB-ID SYNC 0x80, 0x1006 0 (us), 0x100C guard time 0 ms, 0x100D life time factor
  0 (life guarding off until the master sets both [2.1]), 0x1015 EMCY inhibit 0 (100 us).
- 0x1010 / 0x1011 (UNSIGNED32 rw): the appendix uses only sub 2 (communication objects)
  [1.2]; sub 1 ("all parameters", CiA 301) is kept so the array has no hole: it stores /
  restores the communication objects *and* the drive parameters (the C63 = 1 save). Both
  read 1 (the device saves on command). CiA 301 signatures "save" / "load" [DS301].
- 0x1014 COB-ID EMCY $NODEID+0x80 rw [2.6].
- 0x1200-0x1203 SDO servers: RECORD sub 1 (COB-ID client->server) and sub 2 (server->
  client), UNSIGNED32, rw as the object list says; 0x1200 $NODEID+0x600 / $NODEID+0x580,
  0x1201-0x1203 0x80000000 (not valid: the appendix gives no default). No sub 3.
- 0x1400-0x1403 RPDO communication: sub 0 = 2, sub 1 COB-ID and sub 2 transmission type
  only ("only the first 2 sub-indices are managed" [2.4]). 0x1800-0x1803 TPDO
  communication: sub 1-5 ("all 5 managed" [2.3]): COB-ID, type, inhibit (100 us), sub 4
  reserved (UNSIGNED8 rw, CiA 301's compatibility entry), event timer (ms).
- PDO defaults: the appendix gives none and lists no PDO among the objects available at
  first power-up [1.2], so every PDO is *not valid* at power-on: COB-IDs are the CiA 301
  predefined ids with bit 31 set ($NODEID+0x80000200 ..., so a master that only clears bit
  31 gets the usual ids); transmission type 254 (RPDO: applied at once; TPDO: event timer,
  which is 0 = no transmission); empty mappings (sub 0 = 0).
- Mapping records 0x1600-0x1603 / 0x1A00-0x1A03: dynamic, sub 0 and 8 entries, all
  UNSIGNED32 rw (the appendix gives no maximum; every mappable object is 16 or 32 bit, so
  at most 4 entries fill a PDO). Granularity 8.
- Manufacturer arrays (0x200D-0x2012, 0x2016, 0x201E): sub 0 = element count (UNSIGNED8
  ro), element k at sub-index k + 1. The appendix does not give the offset [3.1]; k + 1 is
  CiA 301's usual layout, and the bridge must keep it a setting. The elements take the
  access and mappability of their object.
- DOMAIN objects (0x2001-0x2006, 0x200B, 0x200C, 0x2026) are ro, not mappable, without a
  default in the EDS: their contents are the drive's (the simulator builds them from its
  parameter table); sizes are in the names (1600 / 800 / 128 / 128 / 400 / 200 / 4000 /
  4000 / 1000 bytes, 16-bit little-endian words).
- 0x2000 SDO block size (INTEGER16 rw): no default in the appendix; 127 (the largest CiA
  301 block).
- 0x2016 Tab_inp_dig_field: element 0 (RUN) defaults to 32767 (high at initialisation
  [3.6]), every other element 0. 0x201F Ingressi_standard_wr defaults to 1 (bit 0 = RUN)
  since it is a second view of the same fieldbus channel (the simulator treats them as
  one state; the appendix does not say whether they share storage).
- 0x201B torque limit: no default in the appendix; 32767 (about 800 % of T_nom), so the
  fieldbus limit does not restrict the torque until the master writes it (the most
  restrictive limit wins [3.9]). The other references 0x201A / 0x201C / 0x201D default 0.
- 0x2019 alarm enable mask: 0xFFFF (all alarms enabled; set through P163, whose default
  the appendix does not give either).
- 0x2007 / 0x2008 sensor codes: 1 (incremental encoder) for both, so firmware and board
  agree; the appendix gives no value.
- 0x200D Tab_par / 0x200E Tab_con defaults: the simulator's parameter table
  (drive_bridge/families/opendrive/parameter_table.py): P162 = 1, C48 = 0, C52 = 1, C63 = 0, P60 = 0,
  P163 = 0xFFFF (read as -1 in the INT16 array), the example formats of [6.6]-[6.10]; the
  others 0.
- Baud rates: the C48 codes 1 Mbit/s, 800, 500, 250, 125, 50, 20, 10 kbit/s (no 100 kbit/s
  [1.1]).
"""
from __future__ import annotations

import canopen
from canopen.objectdictionary import datatypes as dt

from drive_bridge.families.edswriter import Device, EdsFile, container, main, mapping_record, members, var, variable
from drive_bridge.families.opendrive.parameter_table import CONNECTIONS, PARAMETERS
from drive_bridge.resources import family_data

I16, U8, U16, U32 = dt.INTEGER16, dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32
VS, DOMAIN = dt.VISIBLE_STRING, dt.DOMAIN
PDO_INVALID = 0x80000000
BAUD_RATES_KBIT = (1000, 800, 500, 250, 125, 50, 20, 10)  # C48 codes 0..7


def communication(od: canopen.ObjectDictionary) -> None:
    add = od.add_object
    add(var('Device type', 0x1000, 0, U32, 'ro', 0))
    add(var('Error register', 0x1001, 0, U8, 'ro', 0))
    add(var('Manufacturer status register', 0x1002, 0, U32, 'ro', 0))
    add(container('Pre-defined error field', 0x1003,
                  [var(f'Standard error field {i}', 0x1003, i, U32, 'ro', 0) for i in range(1, 33)],
                  array=True, count_access='ro', count=0))
    add(var('COB-ID SYNC', 0x1005, 0, U32, 'rw', 0x80))
    add(var('Communication cycle period', 0x1006, 0, U32, 'rw', 0))
    add(var('Manufacturer device name', 0x1008, 0, VS, 'const', 'OPEN drive'))
    add(var('Manufacturer hardware version', 0x1009, 0, VS, 'const', 'unknown'))
    add(var('Manufacturer software version', 0x100A, 0, VS, 'const', 'unknown'))
    add(var('Guard time', 0x100C, 0, U16, 'rw', 0))
    add(var('Life time factor', 0x100D, 0, U8, 'rw', 0))
    add(container('Store parameters', 0x1010, [
        var('Save all parameters', 0x1010, 1, U32, 'rw', 1),
        var('Save communication parameters', 0x1010, 2, U32, 'rw', 1)], array=True))
    add(container('Restore default parameters', 0x1011, [
        var('Restore all default parameters', 0x1011, 1, U32, 'rw', 1),
        var('Restore communication default parameters', 0x1011, 2, U32, 'rw', 1)], array=True))
    add(var('COB-ID EMCY', 0x1014, 0, U32, 'rw', 0x80, relative=True))
    add(var('Inhibit time EMCY', 0x1015, 0, U16, 'rw', 0))
    add(container('Identity object', 0x1018, [
        var('Vendor-ID', 0x1018, 1, U32, 'ro', 0),
        var('Product code', 0x1018, 2, U32, 'ro', 0),
        var('Revision number', 0x1018, 3, U32, 'ro', 0),
        var('Serial number', 0x1018, 4, U32, 'ro', 0)]))
    for n in range(4):
        index = 0x1200 + n
        if n == 0:
            rx, tx = var('COB-ID client->server', index, 1, U32, 'rw', 0x600, relative=True), \
                var('COB-ID server->client', index, 2, U32, 'rw', 0x580, relative=True)
        else:
            rx, tx = var('COB-ID client->server', index, 1, U32, 'rw', PDO_INVALID), \
                var('COB-ID server->client', index, 2, U32, 'rw', PDO_INVALID)
        add(container(f'Server SDO parameter {n + 1}', index, [rx, tx]))


def pdos(od: canopen.ObjectDictionary) -> None:
    """Four RPDOs (communication record sub 0..2 only) and four TPDOs (sub 0..5), none valid."""
    for n in range(1, 5):
        comm, mapping = 0x1400 + n - 1, 0x1600 + n - 1
        od.add_object(container(f'RPDO{n} communication parameter', comm, [
            var('COB-ID', comm, 1, U32, 'rw', PDO_INVALID | (0x100 + 0x100 * n), relative=True),
            var('Transmission type', comm, 2, U8, 'rw', 254)]))
        od.add_object(mapping_record(f'RPDO{n} mapping parameter', mapping))
        comm, mapping = 0x1800 + n - 1, 0x1A00 + n - 1
        od.add_object(container(f'TPDO{n} communication parameter', comm, [
            var('COB-ID', comm, 1, U32, 'rw', PDO_INVALID | (0x80 + 0x100 * n), relative=True),
            var('Transmission type', comm, 2, U8, 'rw', 254),
            var('Inhibit time', comm, 3, U16, 'rw', 0),
            var('Reserved', comm, 4, U8, 'rw', 0),
            var('Event timer', comm, 5, U16, 'rw', 0)]))
        od.add_object(mapping_record(f'TPDO{n} mapping parameter', mapping))


def array(name: str, index: int, count: int, access: str, mappable: bool,
          defaults: dict[int, int] | None = None, data_type: int = I16) -> canopen.objectdictionary.ODArray:
    """An INT16 array of ``count`` elements: element k at sub-index k + 1."""
    defaults = defaults or {}
    members = [var(f'{name}[{k}]', index, k + 1, data_type, access, defaults.get(k, 0), mappable)
               for k in range(count)]
    return container(name, index, members, array=True)  # type: ignore[return-value]


def as_int16(value: int) -> int:
    return value - 0x10000 if value >= 0x8000 else value


def manufacturer(od: canopen.ObjectDictionary) -> None:
    add = od.add_object
    add(var('Block size (SDO block download)', 0x2000, 0, I16, 'rw', 127))
    add(var('Tab_formati (parameter formats, 200 x 4 words)', 0x2001, 0, DOMAIN, 'ro', None))
    add(var('Tab_con_formati (connection formats, 100 x 4 words)', 0x2002, 0, DOMAIN, 'ro', None))
    add(var('Tab_exp_int (internal quantity formats, 64 words)', 0x2003, 0, DOMAIN, 'ro', None))
    add(var('Tab_exp_osc (monitor quantity formats, 64 words)', 0x2004, 0, DOMAIN, 'ro', None))
    add(var('Tab_par_def (parameter defaults, 200 words)', 0x2005, 0, DOMAIN, 'ro', None))
    add(var('Tab_con_def (connection defaults, 100 words)', 0x2006, 0, DOMAIN, 'ro', None))
    add(var('hw_software (speed sensor of the firmware)', 0x2007, 0, I16, 'ro', 1, True))
    add(var('hw_sensore (speed sensor of the feedback board)', 0x2008, 0, I16, 'ro', 1, True))
    add(var('K_zz (monitor buffer counter)', 0x2009, 0, I16, 'ro', 0))
    add(var('Via_alla_conta (monitor trigger flag)', 0x200A, 0, I16, 'ro', 0))
    add(var('Tab_monitor_A (monitor channel A, 2000 points)', 0x200B, 0, DOMAIN, 'ro', None))
    add(var('Tab_monitor_B (monitor channel B, 2000 points)', 0x200C, 0, DOMAIN, 'ro', None))
    add(array('Tab_par', 0x200D, 200, 'rw', False,
              {p.number: as_int16(p.default) for p in PARAMETERS.values()}))
    add(array('Tab_con', 0x200E, 100, 'rw', False,
              {c.number: as_int16(c.default) for c in CONNECTIONS.values()}))
    add(array('Tab_int', 0x200F, 64, 'ro', True))
    add(array('Tab_inp_dig', 0x2010, 32, 'ro', True))
    add(array('Tab_out_dig', 0x2011, 32, 'ro', True))
    add(array('Tab_osc', 0x2012, 64, 'ro', True))
    add(var('ingressi (terminal inputs)', 0x2013, 0, U16, 'ro', 0, True))
    add(var('ingressi_hw (power stage inputs)', 0x2014, 0, U16, 'ro', 0, True))
    add(var('uscite_hw (digital outputs)', 0x2015, 0, U16, 'ro', 0, True))
    add(array('Tab_inp_dig_field', 0x2016, 32, 'rw', True, {0: 32767}))
    add(var('stato (drive status)', 0x2017, 0, U16, 'ro', 0, True))
    add(var('allarmi (alarms)', 0x2018, 0, U16, 'ro', 0, True))
    add(var('abilitazione_allarmi (alarm enable mask)', 0x2019, 0, U16, 'ro', 0xFFFF, True))
    add(var('f_fieldbus (speed reference, 16384 = n_MAX)', 0x201A, 0, I16, 'rw', 0, True))
    add(var('limit_fieldbus (torque limit, 4095 = T_nom)', 0x201B, 0, I16, 'rw', 32767, True))
    add(var('trif_fieldbus (torque reference, 4095 = T_nom)', 0x201C, 0, I16, 'rw', 0, True))
    add(var('theta_fieldbus (speed reference, electrical pulses per PWM period)', 0x201D, 0, I16, 'rw', 0, True))
    add(array('Tab_dati_applicazione', 0x201E, 100, 'rw', True))
    add(var('Ingressi_standard_wr', 0x201F, 0, U32, 'rw', 1, True))
    add(var('Ingressi_appl_wr', 0x2020, 0, U32, 'rw', 0, True))
    add(var('Ingressi_standard_rd', 0x2021, 0, U32, 'ro', 0, True))
    add(var('Ingressi_appl_rd', 0x2022, 0, U32, 'ro', 0, True))
    add(var('Uscite_logiche_rd', 0x2023, 0, U32, 'ro', 0, True))
    add(var('word_vuota', 0x2024, 0, U16, 'rw', 0, True))
    add(var('double_vuota', 0x2025, 0, U32, 'rw', 0, True))
    add(var('Tab_formati_extra (extra parameter formats, 100 x 5 words)', 0x2026, 0, DOMAIN, 'ro', None))


def check(reread: canopen.ObjectDictionary) -> None:
    assert 0x1016 not in reread and 0x1017 not in reread, 'the OPEN drive has no heartbeat'
    assert 3 not in members(reread, 0x1400).subindices, 'RPDO communication records have sub 0..2 only'
    assert variable(reread, 0x1014).default == 0x85, 'COB-ID EMCY must be relative to the node id'
    assert variable(reread, 0x1400, 1).default == 0x80000205, 'PDOs are not valid at power-on'
    assert variable(reread, 0x2016, 1).default == 32767, 'fieldbus RUN starts high'
    assert not variable(reread, 0x200D, 1).pdo_mappable and variable(reread, 0x2012, 1).pdo_mappable
    assert len(members(reread, 0x1003).subindices) == 33


DEVICE = Device('unknown (probably TDE MACNO)', 0,
                'OPEN drive (CANopen DS301), drive_bridge model of the CAN bus appendix', 0, 0, BAUD_RATES_KBIT)
FILES = (EdsFile(family_data('opendrive', 'opendrive.eds'), DEVICE, (communication, pdos, manufacturer), check),)

if __name__ == '__main__':
    main(FILES)
