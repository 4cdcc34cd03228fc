"""A simulated OPEN drive (family ``opendrive``; probably TDE MACNO): a CiA DS301 node with no
CiA 402 profile, after the drive's CANopen appendix as summarised in shared/drives/opendrive.md
(numbers in brackets are its sections). Its EDS is drive_bridge/families/opendrive/data/opendrive.eds
(families/opendrive/edsgen.py, whose docstring lists the readings of the object list).

Modules: objects (indices, codes, abort choices), the family's parameter_table (the P / C table
and the format word layout), emcy (EMCY and 0x1003), pdo (PDO rules), motor (the motor model), logic (the
logic input functions and their channels), quantities (actual values and their representation
words), references (the speed and torque references), alarms (A0..A15), memory (the non-volatile
memory, 0x1010 / 0x1011), formats (the format domains), remote (RTR-only TPDOs), options, drive
(the node: :class:`SimOpenDrive`, composed of those parts, registered as the ``opendrive``
simulator on import).

Communication [2]:

- No heartbeat objects (option ``heartbeat`` false). Node guarding (RTR on 0x700 + id, toggle)
  in every booted state; life guarding only while 0x100C x 0x100D != 0, armed by the first
  RTR, the life time clamped to 32767 / ``pwm_frequency`` s (4.096 s at 8 kHz). The reaction
  to a loss is "decided when the firmware is compiled; by default no action" (§2.4): the option
  ``life_guarding_reaction`` is the firmware: ``none`` (default: the drive keeps running on its
  last RUN and references, no EMCY), ``stop`` (RUN forced low while the RTRs stay away, no
  EMCY) or ``alarm`` (alarm A``guarding_alarm``, default A15, trips: latched, the drive stops,
  EMCY 0x1000 if P163 enables it; an alarm reset clears it once the RTRs are back).
- SDO: an expedited download without the size indicator (command 0x22 / 0x26 / 0x2A / 0x2E)
  is refused with 0x05040001 (the appendix gives no code). DOMAIN tables are read by
  segmented upload (block upload falls back to segmented, block download is refused: canopen's
  server). Abort choices: out of range 0x06090031 / 0x06090032, Reserved / TDE parameter written
  while running 0x08000022, key P60 / P99 not set 0x08000020, unmanaged parameter slot
  0x06010002, wrong save / load signature 0x08000020.
- PDOs (pdo module): none valid at power-on; TPDO 0 every SYNC, 1-240 every n-th, 252 / 253 on
  RTR, 254 event timer only (one frame on entering OPERATIONAL or on (re)configuration, then
  every event-timer period), 255 CiA 301 event-driven; RPDO 0-240 at the next SYNC, 254 at once,
  255 refused (not in the appendix's list). Only sub 1 / 2 of 0x1400-0x1403 (sub 3 aborts
  0x06090011). Remapping is accepted with or without invalidating the PDO.
- EMCY (emcy module) [2.6]: 0x1000 when an alarm *enabled* in 0x2019 trips (a disabled alarm
  still trips, shows in 0x2018 and stops the drive, but sends nothing and is not logged),
  0x0000 on an alarm reset that cleared at least one alarm (bytes 3-4: the alarms left);
  error register bit 0 any alarm, bit 1 A3, bit 2 A10/A11/A13, bit 3 A4-A6; 0x1003 =
  alarms << 16 | 0x1000 per enabled trip, 32 entries, cleared at power-on / reset.
- 0x1010 sub 2 "save": the communication objects go to non-volatile memory and NMT resets load
  them from then on; sub 1 also saves the drive parameters (like C63 = 1). 0x1011 sub 2 "load":
  the default communication objects are written to non-volatile memory, in effect only after
  the next power-on (:meth:`power_off` / :meth:`power_on`); sub 1 also the factory drive
  parameters, which NMT reset node already loads.

Drive [3]:

- RUN (logic function I00) = terminal AND fieldbus AND serial channel (and not forced low by
  life guarding); every other standard function is the OR of the channels. Fieldbus channel:
  0x2016[k] (0 / 32767; any non-zero write is high) and 0x201F bit k are one state; 0x2016[0]
  is high at power-on / reset node. Read-back 0x2010[k] / 0x2021 bit k. Terminal channel: 8
  inputs (0x2013), input n assigned to the function in Cn (0..63: I00..I28 standard, I29..I63
  application; C1 = 0 RUN, C2 = 5 alarm reset, ...); a function without a terminal counts as
  high in the RUN AND and low in the OR. Terminal 1 starts high (``terminal_run``). Serial
  channel: RUN high, the rest low. Application functions I29..I60: 0x2020 bit b forces I(29 +
  b), read back in 0x2022; where a terminal controls one, its physical state wins (module
  logic).
- The drive runs while RUN is high and no alarm is latched. References only with C52 = 1
  (factory value: option ``c52``): speed 0x201A (16384 = n_MAX) or 0x201D (electrical pulses per
  PWM period: rpm = theta x f_pwm x 60 / (65536 x pole pairs)), chosen by ``speed_reference``;
  torque 0x201C in ``control_mode: torque``; torque limit |0x201B| (4095 = T_nom; 32767 at
  power-on). Without C52 = 1 the references are 0 (the drive's other sources are not modelled).
- Motor (motor module): first-order lag to the speed reference (``speed_time_constant``),
  torque-limited; coasting down (``coast_time_constant``) while the drive does not run; the
  mechanical angle integrates the speed.
- Actual values (module quantities): Tab_osc 0x2012[k] and Tab_int 0x200F[k] (the same
  quantities in both): ``actual_speed_element`` (100 % = n_MAX) in its representation word
  ``actual_speed_representation`` (default 0x00E1 = direct / 2^14: 16384 = n_MAX),
  ``actual_torque_element`` (100 % = T_nom) in ``actual_torque_representation`` (default 0x0002
  = % of 4095), ``position_element`` (65536 counts per revolution, INT16 wrapping, 0x0001 =
  direct; none by default); the words in 0x2004[k] / 0x2003[k] (0 for the other elements).
  Array element k is at sub-index k + ``array_offset``.
- Alarms A0..A15 (0x2018): :meth:`SimOpenDrive.inject_alarm` / ``clear_alarm_cause``; a rising
  edge of logic function ``alarm_reset_function`` (default 5: 0x201F bit 5, 0x2016[5] or the
  terminal assigned by C2) clears those whose cause is gone. Enable mask 0x2019 = P163.
- Parameters (parameters module): values in 0x200D (P) / 0x200E (C), formats in 0x2001 /
  0x2002 / 0x2026, factory values in 0x2005 / 0x2006; writes checked by class (Reserved:
  drive not running and P60 = ``reserved_key``; TDE: not running and P99 = ``tde_key``) and
  range. C63 = 1 saves P and C to non-volatile memory (C63 reads 0 again); power-on and reset
  node load them. P162 (node id, factory value = the simulated node id) and C48 (bit rate) are
  stored and saved, but the simulated node keeps its id and the bus its bit rate.

Not modelled: 0x2017 status bits (missing from the appendix: reads 0), logic output functions
(0x2011 / 0x2023 / 0x2015 read 0), power-stage inputs 0x2014, the monitor (0x2009-0x200C read
0), SDO servers 2-4 (0x1201-0x1203 are stored only), the lock between SDO servers, block
download, unbuffered segmented writes (no writable object is longer than 4 bytes), a node id
or bit rate change after P162 / C48 + power cycle, any effect of NMT Stopped / Pre-operational
on the motor (it keeps running), the drive's non-CAN reference sources.
"""

from drive_bridge.sim.opendrive.drive import OPENDRIVE_OPTIONS, SimOpenDrive
from drive_bridge.sim.opendrive.emcy import OpenDriveEmcy
from drive_bridge.sim.opendrive.motor import Motor
from drive_bridge.sim.opendrive.pdo import OpenDrivePdoEngine

__all__ = ['Motor', 'OPENDRIVE_OPTIONS', 'OpenDriveEmcy', 'OpenDrivePdoEngine', 'SimOpenDrive']
