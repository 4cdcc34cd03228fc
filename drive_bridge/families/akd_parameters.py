"""Kollmorgen AKD parameters by their ASCII names (``DRV.ACC``, ``FBUS.PARAM04``, ...), over the
drive's ASCII channel, object 0x2026 (shared/drives/akd.md §9.11, the 0x2026 row of §2.9, §1.6,
§8.3; manual §6.2.2.3 and §7.2.1.9).

The channel, as the manual shows it:

- the command is written to 0x2026:1 (VisibleString, write-only) four characters at a time,
  each an expedited download, and ends with "\\r\\n": ``DRV.`` ``FAUL`` ``TS\\r\\n``;
- the reply is read from 0x2026:2 (VisibleString, read-only) four characters at a time:
  ``>No `` ``faul`` ``ts a`` ``ctiv`` ``e\\n\\r\\n``. So a reply is the prompt character ``>``,
  the output lines (each ending "\\n") and "\\r\\n", the same terminator as a command's: a
  reply ends when the characters read so far end with "\\r\\n" (a line inside the output
  ends with "\\n" alone). Reading stops with a named error after :data:`MAX_REPLY`
  characters without it. A chunk the drive answers with nothing (an empty or all-NUL
  chunk, or the SDO abort 0x08000024 "no data available") is asked for again until
  :data:`REPLY_TIMEOUT`.

Reading ``NAME`` sends ``NAME\\r\\n`` and parses the first output line: a number, optionally
followed by the unit in brackets as the AKD terminal prints it (``1000.000 [rpm/s]``), or
else text. Writing sends ``NAME value\\r\\n`` after the checks below, then reads the value
back. A reply whose output starts with ``Error`` is the drive refusing: a ParameterError
carrying the drive's text. Saving sends ``DRV.NVSAVE`` (the same as 0x1010:1 = "save").

The table (:data:`AKD_PARAMETERS`) is every ASCII parameter the report's object dictionary
(§8.3) and §1.6 name, with its object, data type and scaling ("1000:1": the SDO value is
1000 x the ASCII value), access as printed (blank = "rw"), and:

- **range**: what the parameter's CANopen object can carry, i.e. its data type's range
  divided by the scaling (INT32 1:1 -> -2147483648..2147483647; UNSIGNED32 1000:1 ->
  0..4294967.295). The manual prints no other ranges, except the choices of FBUS.PARAM01
  (0, 125, 250, 500, 1000: §1.2) and the on/off switches FBUS.PARAM02 / 04 (§1.6). The
  drive checks its own, narrower, limits and answers with an error text;
- **type**: parameters without scaling are integers; scaled ones take up to 3 decimals;
- **unit**: the unit class the report gives (position / velocity / acceleration in the
  user units of UNIT.PROTARY / VROTARY / ACCROTARY, §7.1), A for the 1000:1 currents (§7.4),
  and the units named in §8.3 (Ohm, ns, Hz); the unit the drive prints wins when it prints one;
- **save_needed**: writable parameters live in RAM until DRV.NVSAVE; NMT reset node and
  power-off discard unsaved values (§10.14), so every writable parameter needs a save,
  except the run-time values marked volatile (AOUT.VALUEU, MT.NUM, PLS.RESET, ...).
  FBUS.PARAM01 (bit rate) takes effect only after a save and a 24 V restart (§1.2).

Unknown names: the channel itself passes any ASCII command to the drive (§6.2.2.3: "an ASCII
communication channel to the drive"), including commands that act (enable, move, ...).
:class:`AkdParameters` refuses names outside the table, with the closest known names
suggested, so a typo never reaches the drive; ``allow_unlisted=True`` passes them through
unchecked (for the AKD's many parameters the CANopen manual does not list).

Known limits: one outstanding transaction per node (a lock per node id and name); a chunk
whose SDO fails leaves the drive with a partial command, so the next transaction first sends
"~\\r\\n", which turns any partial command into an invalid one the drive refuses (its reply
is discarded). Lost SDO responses must not be retried by the port (a repeated chunk would
change the command or drop part of the reply).
"""
from __future__ import annotations

import difflib
import re
import threading
import time
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation

from drive_bridge.families.parameters import (
    ParameterAccess,
    ParameterError,
    ParameterPort,
    ParameterValue,
    format_limit,
    parameter_error,
)

ASCII_CHANNEL = 0x2026
COMMAND_SUB = 1
RESPONSE_SUB = 2
CHUNK = 4  # characters per SDO
TERMINATOR = '\r\n'
PROMPT = '>'
MAX_REPLY = 1024  # characters
REPLY_TIMEOUT = 1.0  # s waiting for the drive to have reply characters
ABORT_NO_DATA = 0x08000024
FLUSH = '~'  # makes a partial command left by a failed transaction invalid
SAVE_COMMAND = 'DRV.NVSAVE'

_INT_RANGES = {
    'i8': (-(1 << 7), (1 << 7) - 1), 'i16': (-(1 << 15), (1 << 15) - 1), 'i32': (-(1 << 31), (1 << 31) - 1),
    'u8': (0, (1 << 8) - 1), 'u16': (0, (1 << 16) - 1), 'u32': (0, (1 << 32) - 1), 'u64': (0, (1 << 64) - 1),
}
_UNITS = {'pos': 'position units', 'vel': 'velocity units', 'acc': 'acceleration units', '-': ''}
_NUMBER = re.compile(r'[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?')
_VALUE = re.compile(r'\s*(' + _NUMBER.pattern + r')\s*(?:\[([^\]]*)\])?\s*')


@dataclass(frozen=True)
class AkdParameter:
    """One row of the table: see the module docstring."""

    name: str
    index: int  # CANopen object (0: none)
    subindex: int
    kind: str  # i8 .. u64, 'text' (read-only text), 'cmd' (a command without value)
    scale: int  # 0: integer (no scaling); 1: "1:1"; 1000: "1000:1"; -1: "var"
    access: str  # 'rw', 'ro', 'wo', 'cmd'
    unit: str
    volatile: bool = False  # a run-time value DRV.NVSAVE does not keep
    restart: bool = False  # takes effect only after DRV.NVSAVE and a 24 V restart
    choices: tuple[int, ...] = ()

    @property
    def numeric(self) -> bool:
        return self.kind in _INT_RANGES

    @property
    def limits(self) -> tuple[Decimal, Decimal] | None:
        """The range of the parameter's object, in ASCII units (None: not a number, or "var")."""
        if not self.numeric or self.scale < 0:
            return None
        low, high = _INT_RANGES[self.kind]
        scale = max(1, self.scale)
        return Decimal(low) / scale, Decimal(high) / scale

    @property
    def save_needed(self) -> bool:
        return self.access == 'rw' and not self.volatile

    @property
    def note(self) -> str:
        if self.restart:
            return 'takes effect only after DRV.NVSAVE and a 24 V restart'
        return ''


# name  object  type  scaling (- none, 1 = 1:1, 1000 = 1000:1, var)  access  unit  [flags: v volatile,
# r restart, choices=a/b/c]. From akd.md §8.3 (as printed; blank access -> rw) and §1.6.
_TABLE = """
DRV.HANDWHEEL 2050:0 i32 1 ro pos
CAP0.PLFB 20A6:0 i32 var ro pos
CAP1.PLFB 20A2:0 i32 var ro pos
VL.ARTYPE1 3405:1 u8 - rw -
VL.ARTYPE2 3405:2 u8 - rw -
VL.ARTYPE3 3405:3 u8 - rw -
VL.ARTYPE4 3405:4 u8 - rw -
VL.ARPF1 3406:1 u32 1000 rw Hz
VL.ARPF2 3406:2 u32 1000 rw Hz
VL.ARPF3 3406:3 u32 1000 rw Hz
VL.ARPF4 3406:4 u32 1000 rw Hz
VL.ARPQ1 3406:5 u32 1000 rw -
VL.ARPQ2 3406:6 u32 1000 rw -
VL.ARPQ3 3406:7 u32 1000 rw -
VL.ARPQ4 3406:8 u32 1000 rw -
VL.ARZF1 3406:9 u32 1000 rw Hz
VL.ARZF2 3406:10 u32 1000 rw Hz
VL.ARZF3 3406:11 u32 1000 rw Hz
VL.ARZF4 3406:12 u32 1000 rw Hz
VL.ARZQ1 3406:13 u32 1000 rw -
VL.ARZQ2 3406:14 u32 1000 rw -
VL.ARZQ3 3406:15 u32 1000 rw -
VL.ARZQ4 3406:16 u32 1000 rw -
VL.FBFILTER 3407:1 i32 1000 rw vel v
VL.KBUSFF 3407:3 u32 - rw -
VL.ERR 3407:4 u32 1 rw vel v
REGEN.TYPE 3412:0 i8 - rw -
REGEN.WATTEXT 3414:0 u8 - rw -
REGEN.TEXT 3415:0 u32 1000 ro -
REGEN.POWER 3416:0 u32 - ro -
IL.FOLDFTHRESH 3420:0 u16 1000 rw A
IL.FOLDFTHRESHU 3421:0 u32 1000 rw A
IL.FRICTION 3422:0 u32 1000 rw A
IL.OFFSET 3423:0 i32 1000 rw A
IL.INTEN 3424:0 u16 - rw -
IL.IFOLD 3425:0 u32 1000 ro A
IL.KACCFF 3426:0 u32 1000 rw -
IL.MIMODE 3427:1 u8 - rw -
IL.MI2TWTHRESH 3427:2 u8 - rw -
IL.MI2T 3427:3 u32 - rw - v
PL.MODPDIR 3430:0 u8 - rw -
MT.SET 3431:0 u16 - rw - v
CS.DEC 3440:1 u32 1 rw acc
CS.VTHRESH 3440:2 u32 1 rw vel
CS.TO 3440:3 u32 - rw -
CS.STATE 3441:0 u8 - ro -
DRV.DIS 3443:0 u16 - ro -
DRV.DBILIMIT 3444:0 u16 1000 ro A
DRV.DISTO 3445:0 u32 - ro -
MOTOR.BRAKERLS 3450:0 u8 - wo -
MOTOR.AUTOSET 3451:0 u8 - rw -
MOTOR.VOLTMAX 3452:0 u16 - rw V
MOTOR.TEMPWARN 3453:0 u32 - rw -
MOTOR.CTF0 3454:0 u32 1000 rw -
MOTOR.LQLL 3455:0 u32 1000 rw -
MOTOR.R 3456:0 u32 1000 rw Ohm
MOTOR.VRATED 3457:1 i32 1000 rw -
MOTOR.VOLTRATED 3457:2 u16 - rw V
MOTOR.VOLTMIN 3457:3 u16 - rw V
CAP0.TRIGGER 3460:1 u8 - rw -
CAP0.MODE 3460:2 u8 - rw -
CAP0.EVENT 3460:3 u8 - rw -
CAP0.PREEDGE 3460:4 u8 - rw -
CAP0.PRESELECT 3460:5 u8 - rw -
CAP1.TRIGGER 3460:6 u8 - rw -
CAP1.MODE 3460:7 u8 - rw -
CAP1.EVENT 3460:8 u8 - rw -
CAP1.PREEDGE 3460:9 u8 - rw -
CAP1.PRESELECT 3460:10 u8 - rw -
AOUT.MODE 3470:1 i8 - rw -
AOUT.VALUE 3470:2 i16 1000 rw V v
AOUT.VALUEU 3470:3 i16 1000 rw V v
AOUT.VSCALE 3470:5 u32 1000 rw -
AOUT.PSCALE 3471:0 u32 1 rw -
AIN.PSCALE 3472:0 u32 1 rw -
DIN1.PARAM 3474:1 u64 - rw -
DIN2.PARAM 3474:2 u64 - rw -
DIN3.PARAM 3474:3 u64 - rw -
DIN4.PARAM 3474:4 u64 - rw -
DIN5.PARAM 3474:5 u64 - rw -
DIN6.PARAM 3474:6 u64 - rw -
DIN7.PARAM 3474:7 u64 - rw -
DOUT1.PARAM 3475:1 u64 - rw -
DOUT2.PARAM 3475:2 u64 - rw -
PL.KI 3480:0 u32 1000 rw -
PL.INTINMAX 3481:1 u32 1 rw pos
PL.INTOUTMAX 3481:2 u32 1 rw -
HOME.PERRTHRESH 3482:0 i32 1 ro pos
PL.ERRWTHRESH 3483:0 i32 1 rw pos
HOME.DIST 3484:0 i32 1 rw pos
FB1.OFFSET 3490:0 i32 1 ro pos
DRV.EMUEMTURN 3491:0 u32 - ro -
DRV.MOTIONSTAT 3492:0 u32 - ro -
DRV.EMUEDIR 3493:0 u8 - ro -
WS.IMAX 3494:1 i16 1000 rw A
WS.DISTMAX 3494:2 i32 1 rw pos
WS.TDELAY3 3494:3 u16 - rw -
WS.VTHRESH 3494:4 i32 1 rw vel
WS.STATE 3494:5 u8 - ro -
WS.ARM 3494:6 u8 - rw - v
FBUS.SYNCDIST 3496:1 u32 - rw ns
FBUS.SYNCACT 3496:2 u32 - rw ns v
FBUS.SYNCWND 3496:3 u32 - rw ns
FBUS.COMPTIME 3496:4 u32 - rw ns
PLS.P1 34A0:1 i32 1 rw pos
PLS.P2 34A0:2 i32 1 rw pos
PLS.P3 34A0:3 i32 1 rw pos
PLS.P4 34A0:4 i32 1 rw pos
PLS.P5 34A0:5 i32 1 rw pos
PLS.P6 34A0:6 i32 1 rw pos
PLS.P7 34A0:7 i32 1 rw pos
PLS.P8 34A0:8 i32 1 rw pos
PLS.WIDTH1 34A1:1 i32 1 rw pos
PLS.WIDTH2 34A1:2 i32 1 rw pos
PLS.WIDTH3 34A1:3 i32 1 rw pos
PLS.WIDTH4 34A1:4 i32 1 rw pos
PLS.WIDTH5 34A1:5 i32 1 rw pos
PLS.WIDTH6 34A1:6 i32 1 rw pos
PLS.WIDTH7 34A1:7 i32 1 rw pos
PLS.WIDTH8 34A1:8 i32 1 rw pos
PLS.T1 34A2:1 u16 - rw -
PLS.T2 34A2:2 u16 - rw -
PLS.T3 34A2:3 u16 - rw -
PLS.T4 34A2:4 u16 - rw -
PLS.T5 34A2:5 u16 - rw -
PLS.T6 34A2:6 u16 - rw -
PLS.T7 34A2:7 u16 - rw -
PLS.T8 34A2:8 u16 - rw -
PLS.EN 34A3:1 u16 - rw -
PLS.RESET 34A3:2 u16 - rw - v
PLS.MODE 34A3:3 u16 - rw -
PLS.STATE 34A3:4 u16 - rw - v
PLS.UNITS 34A4:0 u8 - rw -
DRV.ACC 3501:0 i32 1 rw acc
HOME.ACC 3502:0 i32 1 rw acc
DRV.HWENMODE 3506:0 i32 - rw -
AIN.VALUE 3509:0 i32 1000 ro V
DRV.DEC 3522:0 i32 1 rw acc
HOME.DEC 3524:0 i32 1 rw acc
DRV.DIR 352A:0 i32 - rw -
FB1.ENCRES 3533:0 u32 - ro -
DRV.EMUEMODE 3534:0 u32 - ro -
DRV.EMUERES 3535:0 u32 - ro -
DRV.EMUEZOFFSET 3537:0 u32 - ro -
FB1.SELECT 353B:0 i32 - ro -
PL.KP 3542:0 u32 1000 rw -
VL.KP 3548:0 u32 1000 rw -
VL.KVFF 354B:0 i32 1000 rw -
VL.KI 354D:0 i32 1000 rw -
IL.FB 3558:0 i32 1000 ro A
IL.DIFOLD 3559:0 i32 1000 ro A
IL.FOLDWTHRESH 355A:0 i32 1000 rw A
DIN1.MODE 3562:0 i32 - rw -
DIN2.MODE 3565:0 i32 - rw -
DIN3.MODE 3568:0 i32 - rw -
DIN4.MODE 356B:0 i32 - rw -
IL.LIMITP 356E:0 i32 1000 rw A
IL.LIMITN 356F:0 i32 1000 rw A
MOTOR.TEMPFAULT 3586:0 u32 - rw -
MOTOR.BRAKE 3587:0 i32 - rw -
MOTOR.ICONT 358E:0 u32 1000 rw A
MOTOR.IPEAK 358F:0 u32 1000 rw A
MOTOR.KT 3593:0 u32 1000 rw Nm/A
IL.KPDRATIO 3596:0 u32 1000 ro -
IL.KP 3598:0 i32 1000 rw -
MOTOR.PHASE 359C:0 u32 - rw -
MOTOR.POLES 359D:0 u32 - rw -
MOTOR.VMAX 35A3:0 u32 - rw -
IL.MIFOLD 35A4:0 i32 1000 rw A
MOTOR.INERTIA 35AB:0 u32 1000 rw -
MT.CNTL 35AF:0 u32 - rw -
DRV.OPMODE 35B4:0 i32 - rw - choices=0/1/2
MT.MTNEXT 35BC:0 i32 - rw -
REGEN.REXT 35C2:0 i32 - rw -
PL.ERR 35C5:0 i32 1 ro pos
MT.TPOSWND 35C6:0 i32 1 rw pos
PL.ERRFTHRESH 35C7:0 i32 1 rw pos
UNIT.PIN 35CA:0 i32 - rw -
UNIT.POUT 35CB:0 i32 - rw -
HOME.IPEAK 35E2:0 u32 1 rw -
DRV.NVSAVE 35EB:0 cmd - cmd -
HOME.SET 35F0:0 cmd - cmd -
DRV.STOP 35FE:0 cmd - cmd -
DRV.DISMODE 35FF:0 u32 - rw -
DRV.TEMPERATURES 3610:0 i32 - ro -
MOTOR.TEMP 3612:0 i32 - ro -
VBUS.UVMODE 3617:0 u32 1 rw -
VL.FB 3618:0 i32 1 ro vel
VBUS.VALUE 361A:0 i32 - ro V
VBUS.UVFTHRESH 361D:0 u32 1000 rw V
VL.LIMITP 3622:0 i32 1 rw vel
VL.LIMITN 3623:0 i32 1 rw vel
VL.THRESH 3627:0 i32 1 rw vel
AIN.VSCALE 3629:0 i32 1000 rw -
FB1.ORIGIN 3656:0 u64 1 rw pos
UNIT.ACCROTARY 3659:0 i32 - rw -
MT.NUM 365B:0 i32 - rw - v
UNIT.VROTARY 365F:0 i32 - rw -
UNIT.PROTARY 3660:0 i32 - rw -
MOTOR.TBRAKEAPP 366E:0 i32 - rw -
MOTOR.TBRAKERLS 366F:0 i32 - rw -
WS.TDELAY1 3683:0 u16 - rw -
WS.TDELAY2 3685:0 u16 - rw -
WS.T 36D0:0 u16 - rw -
WS.DISTMIN 36D1:0 u32 1 rw pos
HOME.AUTOMOVE 36D7:0 u32 1000 rw -
WS.NUMLOOPS 36E2:0 u8 - rw -
FBUS.PARAM01 36E5:0 u32 - rw - r choices=0/125/250/500/1000
FBUS.PARAM02 36E6:0 u32 - rw - choices=0/1
FBUS.PARAM03 36E7:0 u32 - rw -
FBUS.PARAM04 36E8:0 u32 - rw - choices=0/1
FBUS.PARAM05 36E9:0 u32 - rw -
FBUS.PARAM06 36EA:0 u32 - rw -
FBUS.PARAM07 36EB:0 u32 - rw -
FBUS.PARAM08 36EC:0 u32 - rw -
FBUS.PARAM09 36ED:0 u32 - rw -
FBUS.PARAM10 36EE:0 u32 - rw -
DIN5.MODE 36F6:0 i32 - rw -
DIN6.MODE 36F9:0 i32 - rw -
DIN7.MODE 36FC:0 u32 - rw -
MT.TVELWND 3856:0 i32 1 rw vel
DRV.FAULTS 0:0 text - ro -
FBUS.REMOTE 0:0 u8 - rw - v choices=0/1
"""

# 0x50xx-0x52xx: all UNSIGNED32, RW, no scaling (akd.md §8.3)
_TABLE_5000 = """
5000 AIN.CUTOFF  5001 AIN.DEADBAND  5002 AIN.ISCALE  5003 AIN.OFFSET  5009 AOUT.ISCALE  500B AOUT.OFFSET
5013 BODE.EXCITEGAP  5015 BODE.IAMP  5016 BODE.INJECTPOINT  5019 BODE.PRBDEPTH  5060 DOUT.RELAYMODE
5080 DRV.ENDEFAULT  5083 DRV.ICONT  5084 DRV.IPEAK  5085 DRV.IZERO  508C FB1.BISSBITS  508F FB1.INITSIGNED
5096 FB1.PFINDCMDU  5097 FB1.POLES  5099 FB1.RESKTR  509A FB1.RESREFPHASE  509C FB1.TRACKINGCAL
50B1 FBUS.PLLTHRESH  50B7 GEAR.ACCMAX  50B9 GEAR.DECMAX  50BB GEAR.IN  50BC GEAR.MODE  50BE GEAR.OUT
50E2 IL.KBUSFF  50FB MOTOR.PITCH  50FE MOTOR.RTYPE  5104 MOTOR.TYPE  510E MT.EMERGMT  5121 PL.ERRMODE
5128 PL.FBSOURCE  5175 SM.I1  5176 SM.I2  5177 SM.MODE  5179 SM.T1  517A SM.T2  517E SWLS.EN
5184 UNIT.ACCLINEAR  5187 UNIT.PLINEAR  518A UNIT.VLINEAR  518E VBUS.OVWTHRESH  51AE VL.FBSOURCE
51B0 VL.GENMODE  51B3 VL.KO  51B8 VL.LMJR  51BA VL.OBSBW  51BB VL.OBSMODE  51CB DIN1.FILTER
51CC DIN2.FILTER  51CD DIN3.FILTER  51CE DIN4.FILTER  51CF DIN5.FILTER  51D0 DIN6.FILTER  51D1 DIN7.FILTER
51E7 MODBUS.PIN  51E8 MODBUS.POUT  51E9 MODBUS.PSCALE  51EC FB2.ENCRES  51ED FB2.MODE  51EE FB2.SOURCE
51EF MOTOR.TBRAKETO  51F0 MODBUS.MSGLOG  520C MODBUS.SCALING  520D DRV.EMUEPULSEWIDTH
520E DRV.EMUECHECKSPEED  5251 AIN.DEADBANDMODE  5252 AIN.MODE  5253 DIO10.DIR  5254 DIO10.INV
5255 DIO11.DIR  5256 DIO11.INV  5257 DIO9.DIR  5258 DIO9.INV  5259 FAULT130.ACTION  525A FAULT131.ACTION
525B FAULT132.ACTION  525C FAULT134.ACTION  525D FAULT702.ACTION  525E IP.MODE  525F LOAD.INERTIA
5260 MOTOR.KE  5261 VBUS.HALFVOLT  5262 FB2.DIR  5263 DRV.HANDWHEELSRC  5264 DRV.HWENDELAY
5265 IL.KPLOOKUPINDEX  5266 IL.KPLOOKUPVALUE  5267 FAULT451.ACTION  5268 MOTOR.BRAKEIMM
"""
_UNITS_5000 = {'VL.OBSBW': 'Hz'}


def _row(line: str) -> AkdParameter:
    name, obj, kind, scaling, access, unit, *flags = line.split()
    index, sub = obj.split(':')
    choices = next((tuple(int(c) for c in f[len('choices='):].split('/')) for f in flags
                    if f.startswith('choices=')), ())
    scale = {'-': 0, '1': 1, '1000': 1000, 'var': -1}[scaling]
    return AkdParameter(name, int(index, 16), int(sub), kind, scale, access, _UNITS.get(unit, unit),
                        volatile='v' in flags, restart='r' in flags, choices=choices)


def _table() -> dict[str, AkdParameter]:
    rows = [_row(line) for line in _TABLE.strip().splitlines()]
    words = _TABLE_5000.split()
    rows += [AkdParameter(name, int(index, 16), 0, 'u32', 0, 'rw', _UNITS_5000.get(name, ''))
             for index, name in zip(words[::2], words[1::2])]
    return {row.name: row for row in rows}


AKD_PARAMETERS: dict[str, AkdParameter] = _table()



@dataclass
class _Channel:
    """The one ASCII channel of a node: a transaction at a time; ``dirty`` after a broken one."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    dirty: bool = False


_CHANNELS: dict[tuple[int, str], _Channel] = {}
_CHANNELS_GUARD = threading.Lock()


def _channel(port: ParameterPort) -> _Channel:
    with _CHANNELS_GUARD:
        return _CHANNELS.setdefault((port.node_id, port.name), _Channel())


def check_text(text: str) -> str | None:
    """Why ``text`` cannot go into a command (None: it can)."""
    bad = [c for c in text if not ' ' <= c <= '~']
    if bad:
        return f'{text!r} has characters the ASCII channel cannot carry ({", ".join(map(repr, bad[:3]))})'
    return None


def parse_reply(reply: str) -> str:
    """The output of a reply: without the prompt, the terminator and surrounding blank lines."""
    text = reply[:-len(TERMINATOR)] if reply.endswith(TERMINATOR) else reply
    if text.startswith('-->'):
        text = text[3:]
    elif text.startswith(PROMPT):
        text = text[1:]
    lines = [line.rstrip('\r').strip() for line in text.split('\n')]
    return '\n'.join(line for line in lines if line)


class AkdParameters(ParameterAccess):
    """The AKD's ASCII parameters of one node, through its ASCII channel 0x2026."""

    def __init__(self, port: ParameterPort, *, allow_unlisted: bool = False, max_reply: int = MAX_REPLY,
                 reply_timeout: float = REPLY_TIMEOUT) -> None:
        self.port = port
        self.allow_unlisted = allow_unlisted
        self.max_reply = max_reply
        self.reply_timeout = reply_timeout
        self._channel = _channel(port)
        self._units: dict[str, str] = {}  # the unit the drive printed, per parameter

    # -- ParameterAccess ----------------------------------------------------------------------------
    def read(self, name: str, drive_object: int = 0) -> ParameterValue:
        spec = self._spec(name, drive_object)
        if spec.access in ('wo', 'cmd'):
            what = 'a command' if spec.access == 'cmd' else 'write-only'
            how = ' (run it with a write of an empty value)' if spec.access == 'cmd' else ''
            raise self._error(spec.name, f'is {what} and cannot be read{how}')
        return self._value(spec, self._command(spec.name, spec.name))

    def write(self, name: str, value_text: str, drive_object: int = 0) -> ParameterValue:
        spec = self._spec(name, drive_object)
        text = self._checked_value(spec, value_text.strip())
        output = self._command(spec.name, f'{spec.name} {text}' if text else spec.name)
        if spec.access == 'rw' and spec.kind != 'cmd':
            return self.read(spec.name)
        return ParameterValue(spec.name, output or text, self._number(text), self._unit(spec), *self._range(spec),
                              spec.access, spec.save_needed, spec.note)

    def save(self, drive_object: int = 0) -> str:
        self._spec(SAVE_COMMAND, drive_object)
        self._command(SAVE_COMMAND, SAVE_COMMAND)
        return (f'{SAVE_COMMAND}: the parameters of node {self.port.node_id} ({self.port.name}) are stored in '
                'non-volatile memory (a new bit rate FBUS.PARAM01 applies after a 24 V restart)')

    # -- checks -------------------------------------------------------------------------------------
    def _error(self, parameter: str, reason: str, drive_text: str = '') -> ParameterError:
        return parameter_error(self.port, parameter, reason, drive_text)

    def _spec(self, name: str, drive_object: int) -> AkdParameter:
        wanted = name.strip().upper()
        if drive_object != 0:
            raise self._error(wanted, f'an AKD has one drive object: drive_object must be 0, not {drive_object}')
        if not wanted:
            raise self._error('', 'no parameter name given (e.g. DRV.ACC)')
        problem = check_text(wanted)
        if problem is not None or ' ' in wanted:
            raise self._error(wanted, problem or 'a parameter name has no spaces (give the value separately)')
        spec = AKD_PARAMETERS.get(wanted)
        if spec is not None:
            return spec
        if self.allow_unlisted:
            return AkdParameter(wanted, 0, 0, 'text', 0, 'rw', '')
        close = difflib.get_close_matches(wanted, list(AKD_PARAMETERS), n=3, cutoff=0.6)
        hint = (f'did you mean {", ".join(close)}?' if close else
                f'the table has {len(AKD_PARAMETERS)} parameters of the AKD CANopen manual, '
                f'e.g. {", ".join(list(AKD_PARAMETERS)[150:153])}')
        raise self._error(wanted, f'unknown AKD parameter; {hint}')

    def _checked_value(self, spec: AkdParameter, text: str) -> str:
        """The value text to send, after the access, type and range checks."""
        if spec.access == 'ro':
            raise self._error(spec.name, 'is read-only')
        if spec.access == 'cmd' or spec.kind == 'cmd':
            if text:
                raise self._error(spec.name, f'is a command and takes no value (got {text!r})')
            return ''
        problem = check_text(text)
        if problem is not None:
            raise self._error(spec.name, problem)
        if not spec.numeric:
            return text  # unlisted parameter: passed as given
        if not text:
            raise self._error(spec.name, 'no value given')
        try:
            value = Decimal(text) if _NUMBER.fullmatch(text) else None
        except InvalidOperation:
            value = None
        if value is None:
            raise self._error(spec.name, f'{text!r} is not a number')
        if spec.scale <= 0 and value % 1:
            raise self._error(spec.name, f'{text} is not an integer')
        if spec.scale > 0 and (value * 1000) % 1:
            raise self._error(spec.name, f'{text} has more than 3 decimals')
        unit = f' {self._unit(spec)}' if self._unit(spec) else ''
        limits = spec.limits
        if limits is not None and value > limits[1]:
            raise self._error(spec.name, f'{text} is above the maximum {format_limit(float(limits[1]))}{unit}')
        if limits is not None and value < limits[0]:
            raise self._error(spec.name, f'{text} is below the minimum {format_limit(float(limits[0]))}{unit}')
        if spec.choices and value not in spec.choices:
            raise self._error(spec.name, f'{text} is not one of {", ".join(map(str, spec.choices))}')
        return str(int(value)) if value == value.to_integral_value() else format(value.normalize(), 'f')

    # -- values -------------------------------------------------------------------------------------
    def _unit(self, spec: AkdParameter) -> str:
        return self._units.get(spec.name, spec.unit)

    def _range(self, spec: AkdParameter) -> tuple[float | None, float | None]:
        if spec.choices:
            return float(min(spec.choices)), float(max(spec.choices))
        limits = spec.limits
        return (float(limits[0]), float(limits[1])) if limits is not None else (None, None)

    @staticmethod
    def _number(text: str) -> float | None:
        return float(text) if _NUMBER.fullmatch(text) else None

    def _value(self, spec: AkdParameter, output: str) -> ParameterValue:
        first = output.split('\n', 1)[0] if output else ''
        match = _VALUE.fullmatch(first) if '\n' not in output else None
        value = float(match.group(1)) if match else None
        if match and match.group(2):
            self._units[spec.name] = match.group(2).strip()
        value_text = match.group(1) if match else output
        return ParameterValue(spec.name, value_text, value, self._unit(spec), *self._range(spec), spec.access,
                              spec.save_needed, spec.note)

    # -- the channel --------------------------------------------------------------------------------
    def _command(self, parameter: str, command: str) -> str:
        """Send ``command``, return the drive's output; ParameterError for an error reply."""
        channel = self._channel
        with channel.lock:
            if channel.dirty:
                try:
                    self._exchange(parameter, FLUSH)
                except ParameterError:
                    pass
                channel.dirty = False
            try:
                output = parse_reply(self._exchange(parameter, command))
            except ParameterError:
                channel.dirty = True
                raise
        if output.lower().startswith('error'):
            raise self._error(parameter, f'the drive refused {command!r}: {output}', drive_text=output)
        return output

    def _exchange(self, parameter: str, command: str) -> str:
        line = command + TERMINATOR
        for start in range(0, len(line), CHUNK):
            chunk = line[start:start + CHUNK]
            try:
                self.port.sdo_write_raw(ASCII_CHANNEL, COMMAND_SUB, chunk.encode('ascii'))
            except Exception as exc:  # the port's SDO error, whatever its type
                raise self._error(parameter, f'sending {command!r} to the ASCII channel 0x2026:1 failed at '
                                             f'character {start}: {exc}') from exc
        reply = ''
        deadline = time.monotonic() + self.reply_timeout
        while not reply.endswith(TERMINATOR):
            if len(reply) >= self.max_reply:
                raise self._error(parameter, f'the reply to {command!r} did not end (no "\\r\\n") within '
                                             f'{self.max_reply} characters: {reply[:60]!r}...')
            chunk = self._read_chunk(parameter, command)
            if chunk:
                reply += chunk
                continue
            if time.monotonic() > deadline:
                got = f' after {reply!r}' if reply else ''
                raise self._error(parameter, f'no reply to {command!r} from the ASCII channel 0x2026:2 within '
                                             f'{self.reply_timeout:g} s{got}')
            time.sleep(0.002)
        return reply

    def _read_chunk(self, parameter: str, command: str) -> str:
        try:
            data = self.port.sdo_read_raw(ASCII_CHANNEL, RESPONSE_SUB)
        except Exception as exc:
            if getattr(exc, 'abort_code', None) == ABORT_NO_DATA:
                return ''
            raise self._error(parameter, f'reading the reply to {command!r} from the ASCII channel 0x2026:2 '
                                         f'failed: {exc}') from exc
        return data.replace(b'\x00', b'').decode('ascii', errors='replace')
