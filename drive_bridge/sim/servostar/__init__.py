"""A simulated Kollmorgen SERVOSTAR 400/600 (family ``servostar``): the CiA 402 drive with the
SERVOSTAR's own rules where a master can observe them (German manual 12/2009 as summarised in
shared/drives/servostar-400-600.md; numbers in brackets are its sections). The object
dictionary is families/servostar/data/servostar.eds (families/servostar/edsgen.py, whose docstring records
how the manual was read).

Modules: objects (indices, library, codes, units), emcy (category byte, follow-up frame), pdo
(library PDOs), modes (manufacturer modes), units (counts, increments, user units, ramps),
status (statusword bits, 0x1002, the actual values), storage (SAVE, 0x1010:2), axis (state
machine, modes, error reactions; its part: units), ascii (the PDO 21 terminal), drive (the
node: :class:`SimServostar`, registered as the ``servostar`` simulator on import; its parts:
storage, the terminal).

CiA 301 [2]:

- Boot-up [2.3]: no 0x700 frame; the power-on telegram is an EMCY on 0x1014 (0x80 + node) with 8
  zero bytes, or 0 bytes when a DRVCNFG bit is set: bit 0 (§2.6, default) or bit 2 (§6.1.1), by
  the option ``bootup_length_bit``. Sent at power-on, NMT reset node and every restart (COLDSTART,
  controlword bit 7). The CAN controller's re-transmission while nobody acknowledges is not
  modelled (the virtual bus always acknowledges).
- NMT [2.2]: start, stop; reset node (0x81) is a cold start: every unsaved value is lost (the
  values saved by SAVE / 0x1010:2 come back). Enter pre-operational and reset communication are
  not in the manual: obeyed as CiA 301 (option ``nmt_undocumented``: 'ignore').
- No heartbeat (0x1016/0x1017 absent). Node guarding (RTR on 0x700 + node, toggle bit, NMT state
  4 / 5 / 127); life guarding (0x100C x 0x100D, armed by the first RTR) only while the output
  stage is enabled (Switched On, Operation Enabled, Quick Stop Active): the life time starts
  again whenever the stage is switched on. On timeout: warning n04 (0x1002 bit 3, statusword
  bit 7), EMCY 0x8181 category 2, the axis brakes on the emergency (quick-stop) ramp DECSTOP and
  motion stays blocked; RTRs coming back change nothing; controlword bit 11 (rising) clears it.
- SDO [2.4]: expedited only: segmented and block requests are answered with abort 0x05040001.
  Without DRVCNFG bit 2 the size of an expedited download is fitted to the object (the manual
  writes 16-bit objects with 4-byte and 32-bit objects with 2-byte frames); with it a wrong size
  aborts 0x06070010. 0x6060 is write-only (an upload aborts 0x06010001).
- EMCY [2.10, 3] (module emcy): byte 3 = category (the manual's table; unknown codes category
  1, PDO errors 3), bytes 4..7 zero; error register: only the bit of the code's class, bit 7 for
  a code of no class (4310h gives 08h as §6.1.10 / §6.2.1.1 print; option
  ``emcy_error_register``); every error EMCY is followed by an EMCY 0x0000 with the present
  error register and byte 3 00h (the frame §6.2.1.1 prints; option ``emcy_follow_up_category``);
  an acknowledge / reset sends 0x0000 with the remaining register. 0x1003 holds the last error
  only.
- PDOs [2.5-2.8]: four channels per direction; 0x2600-0x2603 / 0x2A00-0x2A03 select a library
  PDO by number (RPDO 1, 21, 22, 32, 33, 34, 35, 41; TPDO 1, 21, 22, 23, 32, 33, 34, 41; free
  37-40; 0 = empty; reserved numbers abort 0x06090030) and 0x16xx / 0x1Axx show its mapping;
  they are read-only (abort 0x06010002) unless a free PDO is selected. Free mapping: write sub 0
  = 0 (deletes the PDO's entries), then entries 1, 2, ... (appended; sub 0 counts them; writing
  sub 0 = n is accepted too); up to 8 entries and 64 bits; 24-bit entries allowed. Selecting a
  free PDO starts it empty (unless it was already selected in that channel). Transmission types:
  RPDO 21/34/35 and TPDO 21 only 255, RPDO 33 and TPDO 32/33 only 1..240 (others abort
  0x06090030; selecting such a PDO replaces an unfit type by 255 / 1; RPDO 33 frames are not
  processed asynchronously). No event timer (sub 5 absent). Mappings and COB-IDs of valid PDOs
  may be changed directly (the manual's examples never set bit 31). Event-driven TPDO 1..4 are
  filtered by the change masks 0x2014-0x2017. With MDRV = 1 only RPDO channels 1-3 are served.
  The PDO configuration comes back at power-on / reset as the library defaults (RPDO 1 = PDO 1,
  RPDO 2 = PDO 21, TPDO 1 = PDO 1, TPDO 2 = PDO 21), unless DRVCNFG bit 3 was set and 0x1010:2
  "save" stored it (0x1010:2 aborts 0x08000020 without bit 3 or signature).
- RPDO 33 [5]: one 8-byte frame for two drives (both RPDOs on the same COB-ID); 0x2721 picks
  this drive's half (option ``pdo33_half_select``: 'offset' 0 / 4 as the worked example, 'index'
  0 / 1 as the object text, 'nonzero'); the half is written to 0x2022:04 at the SYNC.
- ASCII [8.3, 9.7]: the object channel 0x3500+ (sub 1 = value; implemented: MAXSDO, ACC, ADDR,
  AENA, CBAUD, CLRFAULT, CLRWARN, DEC, DECSTOP, DRVSTAT, OPMODE, PEMAX (= 0x2020:03), PRBASE,
  PTBASE, SAVE, VLIM, COLDSTART, MDRV, DRVCNFG) and the PDO 21 terminal (module ascii).
- SAVE (35EBh) stores the object channel's EEPROM parameters and 0x2020, 0x2024, 0x607B, 0x607C,
  0x6086, 0x6098, 0x6099, 0x609A, 0x60C2 as power-on values; COLDSTART (3632h, only with the
  stage off: else abort 0x08000022 + EMCY 0x7182) restarts the drive.

CiA 402 [4-7]:

- State machine: no Fault / Fault Reaction Active state. 0x0007 and 0x000F are accepted directly
  from Switch On Disabled. Transition 3 needs the hardware enable input
  (:meth:`SimServostar.set_hardware_enable`), the DC link and no category 1 error: otherwise
  the drive stays in Ready to Switch On with EMCY 0x7181 (category 5). Quick stop brakes on
  DECSTOP and stays in Quick Stop Active (0x605A default 6; enable again = transition 16) and
  clears the setpoints (0x2060, 0x60FF, task number, VREF, VJOG). Disable operation ramps down
  (the mode's ramp), then Switched On; shutdown switches the stage off at once.
- Errors: category 1 (and 4): EMCY pair, 0x1002 bit 31, ERRCODE bit; the output stage goes off
  and the state machine follows to Switch On Disabled (as DRVCNFG bit 1 describes; bit 1 = 0,
  "not influenced", is not modelled); controlword bit 7 (rising) or COLDSTART / CLRFAULT restarts
  the drive (boot EMCY again, unsaved values lost). Category 2 (0x8611 following error, 0x8181
  response monitoring, 0x8682, ...): EMCY pair, bit 31, emergency ramp in Operation Enabled,
  motion blocked (also after a re-enable) until controlword bit 11 (rising) or CLRFAULT.
  Categories 3 and 5: the EMCY pair only. ``inject_fault(code, category=None, persistent=False)``.
- 0x1002 / DRVSTAT (2080h:03-06 its bytes, 2080h:07-0A TRJSTAT's, the same here): bit 16
  (motion task active) from the start of a motion task (FFh), a homing (F9h, hm 6) or an
  acknowledged pp set-point to its end; bit 17 (reference set) cleared when a homing starts, set
  when it ends; bits 18 (at the home position, within PEINPOS of ROFFS) and 19 (in position:
  standstill within PEINPOS) only while no task runs (§6.1.6: 2080h:09 = 03h at the
  acknowledge, 0Ah at the target).
- Statusword: bit 4 inverted (1 = no DC link, :meth:`SimServostar.set_dc_link`), bit 9 never,
  bit 7 while a warning (0x1002 bits 0..15) is pending, bit 8 toggles at every completed motion
  task / pp target, bit 11 only with DRVCNFG bit 20 (warnings n04, n06, n07, n09-n11, n13), bit
  3 never (option ``fault_bit3``: while an error is pending), bit 12 in 0xFE = speed 0.
- Modes: 0x6060 accepts -1 (0xFF direct motion task 0), -2 (0xFE digital speed), -3 (0xFD digital
  current), -4 / -5 / -9 (analog and gearing: hold), -6 (0xFA trajectory), -7 (0xF9 homing),
  -8 (0xF8 jog), 1 (pp), 3 (pv), 6 (hm); others (vl 2, tq 4, ip 7, ...) abort 0x06090030. A mode
  takes effect at the drive's next cycle at standstill only (0x6061 shows it; with the motor
  turning the request waits); the new mode's setpoint (0x2060, 0x60FF) is cleared. Power-on mode
  from OPMODE (35B4h): the default 8 (position) comes up as 0xF9 homing.
- Trajectory 0xFA [5]: each SYNC takes the 0x2022:04 received before it (absolute, 2^PRBASE per
  revolution; option ``trajectory_setpoints``: 'relative'), the commanded position runs linearly
  to it over PTBASE (as read at power-on: PTBASE, 60C2h, PRBASE are saved and take effect after a
  restart); the demand follows at most at VLIM. A SYNC interval off PTBASE by more than 25 %
  makes the profile dip and is counted (option ``trajectory_timing``: 'error' = 0x8682 after
  three in a row); a step beyond VLIM x PTBASE is counted and the demand falls behind (option
  ``trajectory_step_check``: 'error' = 0x8611 at once); |command - actual| beyond PEMAX
  (0x2020:03, user units; 0 = off) raises 0x8611 category 2 (warning n03) and the emergency
  ramp; bit 11 clears it. PEMAX is also checked (demand - actual) in the other position modes.
- Units: the model counts 2^20 per revolution; 0x6063 / 0x2022:04 in 2^PRBASE; 0x2070:03 in
  2^20 (option ``actual_position_resolution``: 'prbase'); 0x2070:01 24-bit position in 16
  revolutions, 0x2070:02 / 0x2060 speed 1875/262144 rpm per bit; 0x6064 / 0x607A user units by
  0x6093 (2^20 / 10000); 0x606C / 0x60FF / 0x6081 by 0x6094 (0/0: increments per 250 us); 0x2020
  / 0x2024 / 0x2070:06-08 user units by PGEARI / PGEARO; 0x6083 / 0x6084 ramp times in ms (to
  0x6081 in pp, to VLIM in pv; 0 = ACC / DEC), ACC / DEC to VLIM in 0xFE, DECSTOP to VLIM; VLIM
  in rpm; 0x2060 current 1640 = rated (1000 per mille), 3280 = peak.

Not modelled: stored motion tasks 1-180 / 192-255 (they answer EMCY 0x8681), motion-task chaining
and type bits beyond absolute / relative, analog inputs, gearing, latches, position registers,
TPDO 34 / 41 contents (0), BUSOFF, the PLL and SYNCSRC, the DRVCNFG bit 1 = 0 behaviour, the
EMCY of DRVCNFG bit 2's length check, the CPU-load effect of free TPDOs, ``CLRFAULT`` resets
without restart, an EMCY on a refused PDO mode.
"""

from drive_bridge.sim.servostar.axis import ServostarAxis
from drive_bridge.sim.servostar.drive import SERVOSTAR_OPTIONS, SimServostar
from drive_bridge.sim.servostar.emcy import ServostarEmcy
from drive_bridge.sim.servostar.pdo import ServostarPdoEngine

__all__ = ['SERVOSTAR_OPTIONS', 'ServostarAxis', 'ServostarEmcy', 'ServostarPdoEngine', 'SimServostar']
