"""The simulated AKD's ASCII channel, object 0x2026 (shared/drives/akd.md §9.11 and the 0x2026
row of §2.9; manual §6.2.2.3, §7.2.1.9), with the ASCII parameters behind it.

What the drive does, as the manual shows it and as modelled here:

- 0x2026:0 = 2; 0x2026:1 "Command", VisibleString, write-only: each expedited download
  carries up to 4 characters, appended to a command buffer (a longer download is refused
  with 0x06070012); when the buffer holds "\\r\\n" the command before it is executed;
  0x2026:2 "Response", VisibleString, read-only: each upload returns the next (up to) 4
  characters of the reply; with no reply characters left it aborts 0x08000024 ("no data
  available"; canopen's server for an empty value).
- A reply is ``>``, the output lines each ending "\\n", then "\\r\\n": the manual's
  ``>No faults active\\n\\r\\n`` for DRV.FAULTS. A command without output (a write) gets
  ``>\\r\\n``. A new command discards what is left of the previous reply.
- ``NAME`` reads a parameter: an integer, or a number with 3 decimals for scaled
  parameters, followed by its unit in brackets when it has one (``104857600.000
  [counts/s^2]``); ``NAME value`` writes it; ``DRV.NVSAVE``, ``HOME.SET``, ``DRV.STOP`` are
  commands. Names are case-insensitive.
- Errors are answered as text (the manual prints none; these are the simulator's):
  ``Error: Unknown command``, ``Error: Parameter is read-only``, ``Error: Parameter is
  write-only``, ``Error: Invalid argument``, ``Error: Argument above maximum (...)`` /
  ``below minimum (...)``, ``Error: Invalid value (allowed: ...)``, ``Error: Command too
  long``, and for the control commands (DRV.STOP, HOME.SET, MOTOR.BRAKERLS) while the
  fieldbus controls the drive (FBUS.REMOTE = 1): ``Error: Drive is controlled by the
  fieldbus (FBUS.REMOTE = 1)`` [4.1: "no control command over another channel"].

The parameters (every ASCII parameter of akd.md §8.3 and §1.6, the drive's own transcription,
independent of the bridge's table): each is its CANopen object, so SDO and ASCII see one
value (SDO = ASCII value x 1000 for "1000:1" parameters). Objects the EDS lacks are added to
the simulated dictionary (their value is stored; nothing in the model acts on them), so
power-on and NMT reset node discard unsaved values and DRV.NVSAVE (= 0x1010:1 "save") makes
the present values the power-on values [10.14]. The 64-bit DINx.PARAM / DOUTx.PARAM are
split over their low and high 32-bit sub-indices. Ranges are the objects' data types (scaled),
plus the documented choices of FBUS.PARAM01 (bit rates, §1.2) and the on/off switches.
FBUS.REMOTE reads and sets the simulated drive's ``remote`` (statusword bit 9); DRV.FAULTS
lists the active EMCY codes. Units: the simulated drive's user units are counts.
The command buffer and an unread reply survive an NMT reset (the manual does not say).

Install on a simulated slave with ``AsciiChannel(slave).install()``.
"""
from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from typing import Any

from canopen.objectdictionary import ODVariable, datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.store import ObjectStore, key

ASCII_CHANNEL = 0x2026
COMMAND, RESPONSE = 1, 2
CHUNK = 4
TERMINATOR = '\r\n'
MAX_COMMAND = 128  # characters in the command buffer without "\r\n"
ABORT_TOO_LONG = 0x06070012  # data type does not match, length of service parameter too high

_TYPES = {'i8': dt.INTEGER8, 'i16': dt.INTEGER16, 'i32': dt.INTEGER32, 'u8': dt.UNSIGNED8,
          'u16': dt.UNSIGNED16, 'u32': dt.UNSIGNED32, 'u64': dt.UNSIGNED64}
_RANGES = {'i8': (-(1 << 7), (1 << 7) - 1), 'i16': (-(1 << 15), (1 << 15) - 1), 'i32': (-(1 << 31), (1 << 31) - 1),
           'u8': (0, 255), 'u16': (0, (1 << 16) - 1), 'u32': (0, (1 << 32) - 1), 'u64': (0, (1 << 64) - 1)}
_CONTROL_COMMANDS = frozenset({'DRV.STOP', 'HOME.SET', 'MOTOR.BRAKERLS'})
_NUMBER = re.compile(r'[-+]?(?:\d+(?:\.\d*)?|\.\d+)')

# name  object  type  scaling (- none, 1 = 1:1, 1000 = 1000:1, var)  access (blank in the manual: rw)
# unit (as the drive prints it; - none)  [choices=a/b/c]
_TABLE = """
DRV.HANDWHEEL 2050:0 i32 1 ro counts
CAP0.PLFB 20A6:0 i32 var ro counts
CAP1.PLFB 20A2:0 i32 var ro counts
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
VL.FBFILTER 3407:1 i32 1000 rw counts/s
VL.KBUSFF 3407:3 u32 - rw -
VL.ERR 3407:4 u32 1 rw counts/s
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
IL.MI2T 3427:3 u32 - rw -
PL.MODPDIR 3430:0 u8 - rw -
MT.SET 3431:0 u16 - rw -
CS.DEC 3440:1 u32 1 rw counts/s^2
CS.VTHRESH 3440:2 u32 1 rw counts/s
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
AOUT.VALUE 3470:2 i16 1000 rw V
AOUT.VALUEU 3470:3 i16 1000 rw V
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
PL.INTINMAX 3481:1 u32 1 rw counts
PL.INTOUTMAX 3481:2 u32 1 rw -
HOME.PERRTHRESH 3482:0 i32 1 ro counts
PL.ERRWTHRESH 3483:0 i32 1 rw counts
HOME.DIST 3484:0 i32 1 rw counts
FB1.OFFSET 3490:0 i32 1 ro counts
DRV.EMUEMTURN 3491:0 u32 - ro -
DRV.MOTIONSTAT 3492:0 u32 - ro -
DRV.EMUEDIR 3493:0 u8 - ro -
WS.IMAX 3494:1 i16 1000 rw A
WS.DISTMAX 3494:2 i32 1 rw counts
WS.TDELAY3 3494:3 u16 - rw -
WS.VTHRESH 3494:4 i32 1 rw counts/s
WS.STATE 3494:5 u8 - ro -
WS.ARM 3494:6 u8 - rw -
FBUS.SYNCDIST 3496:1 u32 - rw ns
FBUS.SYNCACT 3496:2 u32 - rw ns
FBUS.SYNCWND 3496:3 u32 - rw ns
FBUS.COMPTIME 3496:4 u32 - rw ns
PLS.P1 34A0:1 i32 1 rw counts
PLS.P2 34A0:2 i32 1 rw counts
PLS.P3 34A0:3 i32 1 rw counts
PLS.P4 34A0:4 i32 1 rw counts
PLS.P5 34A0:5 i32 1 rw counts
PLS.P6 34A0:6 i32 1 rw counts
PLS.P7 34A0:7 i32 1 rw counts
PLS.P8 34A0:8 i32 1 rw counts
PLS.WIDTH1 34A1:1 i32 1 rw counts
PLS.WIDTH2 34A1:2 i32 1 rw counts
PLS.WIDTH3 34A1:3 i32 1 rw counts
PLS.WIDTH4 34A1:4 i32 1 rw counts
PLS.WIDTH5 34A1:5 i32 1 rw counts
PLS.WIDTH6 34A1:6 i32 1 rw counts
PLS.WIDTH7 34A1:7 i32 1 rw counts
PLS.WIDTH8 34A1:8 i32 1 rw counts
PLS.T1 34A2:1 u16 - rw -
PLS.T2 34A2:2 u16 - rw -
PLS.T3 34A2:3 u16 - rw -
PLS.T4 34A2:4 u16 - rw -
PLS.T5 34A2:5 u16 - rw -
PLS.T6 34A2:6 u16 - rw -
PLS.T7 34A2:7 u16 - rw -
PLS.T8 34A2:8 u16 - rw -
PLS.EN 34A3:1 u16 - rw -
PLS.RESET 34A3:2 u16 - rw -
PLS.MODE 34A3:3 u16 - rw -
PLS.STATE 34A3:4 u16 - rw -
PLS.UNITS 34A4:0 u8 - rw -
DRV.ACC 3501:0 i32 1 rw counts/s^2
HOME.ACC 3502:0 i32 1 rw counts/s^2
DRV.HWENMODE 3506:0 i32 - rw -
AIN.VALUE 3509:0 i32 1000 ro V
DRV.DEC 3522:0 i32 1 rw counts/s^2
HOME.DEC 3524:0 i32 1 rw counts/s^2
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
PL.ERR 35C5:0 i32 1 ro counts
MT.TPOSWND 35C6:0 i32 1 rw counts
PL.ERRFTHRESH 35C7:0 i32 1 rw counts
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
VL.FB 3618:0 i32 1 ro counts/s
VBUS.VALUE 361A:0 i32 - ro V
VBUS.UVFTHRESH 361D:0 u32 1000 rw V
VL.LIMITP 3622:0 i32 1 rw counts/s
VL.LIMITN 3623:0 i32 1 rw counts/s
VL.THRESH 3627:0 i32 1 rw counts/s
AIN.VSCALE 3629:0 i32 1000 rw -
FB1.ORIGIN 3656:0 u64 1 rw counts
UNIT.ACCROTARY 3659:0 i32 - rw -
MT.NUM 365B:0 i32 - rw -
UNIT.VROTARY 365F:0 i32 - rw -
UNIT.PROTARY 3660:0 i32 - rw -
MOTOR.TBRAKEAPP 366E:0 i32 - rw -
MOTOR.TBRAKERLS 366F:0 i32 - rw -
WS.TDELAY1 3683:0 u16 - rw -
WS.TDELAY2 3685:0 u16 - rw -
WS.T 36D0:0 u16 - rw -
WS.DISTMIN 36D1:0 u32 1 rw counts
HOME.AUTOMOVE 36D7:0 u32 1000 rw -
WS.NUMLOOPS 36E2:0 u8 - rw -
FBUS.PARAM01 36E5:0 u32 - rw - choices=0/125/250/500/1000
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
MT.TVELWND 3856:0 i32 1 rw counts/s
DRV.FAULTS 0:0 text - ro -
FBUS.REMOTE 0:0 u8 - rw - choices=0/1
"""

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

# power-on values of the parameters the EDS does not hold (simulation values, not the manual's)
SIM_VALUES: dict[str, float] = {
    'MOTOR.ICONT': 3.0, 'MOTOR.IPEAK': 9.0, 'MOTOR.KT': 0.7, 'MOTOR.POLES': 6, 'MOTOR.VMAX': 6000,
    'MOTOR.R': 2.4, 'MOTOR.INERTIA': 0.5, 'MOTOR.VOLTMAX': 400, 'MOTOR.TEMPFAULT': 140, 'MOTOR.TEMPWARN': 120,
    'MOTOR.TEMP': 30, 'DRV.TEMPERATURES': 35, 'VBUS.VALUE': 320, 'VBUS.UVFTHRESH': 90.0,
    'DRV.ICONT': 6, 'DRV.IPEAK': 18, 'IL.LIMITP': 9.0, 'IL.LIMITN': -9.0, 'IL.KP': 50.0, 'PL.KP': 50.0,
    'VL.KP': 0.05, 'VL.KI': 10.0, 'VL.LIMITP': 100 * 2 ** 20, 'VL.LIMITN': -100 * 2 ** 20,
    'VL.THRESH': 110 * 2 ** 20, 'PL.ERRFTHRESH': 2 ** 20, 'HOME.ACC': 10 * 2 ** 20, 'HOME.DEC': 10 * 2 ** 20,
    'UNIT.PIN': 1, 'UNIT.POUT': 1, 'UNIT.PROTARY': 3, 'UNIT.VROTARY': 3, 'UNIT.ACCROTARY': 3,
    'DRV.OPMODE': 2, 'FB1.ENCRES': 2 ** 20, 'FBUS.PLLTHRESH': 1000, 'WS.NUMLOOPS': 1,
}


@dataclass(frozen=True)
class SimParameter:
    name: str
    keys: tuple[int, ...]  # store keys of its object (two: a 64-bit value over low/high U32); () computed
    kind: str  # i8 .. u64, 'text', 'cmd'
    scale: int  # 0 none, 1 "1:1", 1000 "1000:1", -1 "var"
    access: str  # rw, ro, wo, cmd
    unit: str
    choices: tuple[int, ...] = ()


def _parameters() -> dict[str, SimParameter]:
    rows: list[tuple[str, str, str, str, str, str, list[str]]] = []
    for line in _TABLE.strip().splitlines():
        name, obj, kind, scaling, access, unit, *flags = line.split()
        rows.append((name, obj, kind, scaling, access, unit, flags))
    words = _TABLE_5000.split()
    rows += [(name, f'{index}:0', 'u32', '-', 'rw', 'Hz' if name == 'VL.OBSBW' else '-', [])
             for index, name in zip(words[::2], words[1::2])]
    table: dict[str, SimParameter] = {}
    for name, obj, kind, scaling, access, unit, flags in rows:
        index_text, sub_text = obj.split(':')
        index, sub = int(index_text, 16), int(sub_text)
        keys: tuple[int, ...] = ()
        if index and kind == 'u64' and index in (0x3474, 0x3475):  # low / high 32 bits
            keys = (key(index, sub), key(index, sub + (7 if index == 0x3474 else 2)))
        elif index and kind != 'cmd':
            keys = (key(index, sub),)
        choices = next((tuple(int(c) for c in f[8:].split('/')) for f in flags if f.startswith('choices=')), ())
        table[name] = SimParameter(name, keys, kind, {'-': 0, '1': 1, '1000': 1000, 'var': -1}[scaling], access,
                                   '' if unit == '-' else unit, choices)
    return table


PARAMETERS: dict[str, SimParameter] = _parameters()


def _variable(name: str, index: int, subindex: int, data_type: int, access: str, default: Any) -> ODVariable:
    var = ODVariable(name, index, subindex)
    var.data_type = data_type
    var.access_type = access
    var.default = default
    return var


def _ensure(store: ObjectStore, var: ODVariable) -> None:
    """Add an object the EDS lacks (the EDS's own wins)."""
    k = key(var.index, var.subindex)
    if k in store:
        return
    if not any(store.keys_between(var.index, var.index)):
        if var.subindex == 0:
            store.add(var)
            return
        count = _variable('Highest sub-index supported', var.index, 0, dt.UNSIGNED8, 'ro', 0)
        store.add(count)
    # a further sub-index of a record (ObjectStore.add takes plain variables only)
    store.variables[k] = var
    store.defaults[k] = store.values[k] = var.default
    count_key = key(var.index, 0)
    if count_key in store and store.variables[count_key].access_type == 'ro':
        store.defaults[count_key] = store.values[count_key] = max(store.defaults[count_key], var.subindex)


class AsciiChannel:
    """0x2026 of a simulated AKD; see the module docstring. ``save`` (default: every object's
    present value becomes its power-on value) is what DRV.NVSAVE does."""

    def __init__(self, slave: Any, save: Callable[[], None] | None = None) -> None:
        self.slave = slave
        self.store: ObjectStore = slave.store
        self._save = save
        self._buffer = ''
        self._reply = ''
        self.commands: list[str] = []  # every command executed (for tests)

    def install(self) -> AsciiChannel:
        store = self.store
        _ensure(store, _variable('ASCII channel: command', ASCII_CHANNEL, COMMAND, dt.VISIBLE_STRING, 'wo', ''))
        _ensure(store, _variable('ASCII channel: response', ASCII_CHANNEL, RESPONSE, dt.VISIBLE_STRING, 'ro', ''))
        for parameter in PARAMETERS.values():
            self._add_object(parameter)
        self.slave.register_object(ASCII_CHANNEL, COMMAND, validator=self._check_chunk, on_write=self._on_chunk)
        self.slave.register_object(ASCII_CHANNEL, RESPONSE, reader=self._next_chunk)
        return self

    def _add_object(self, parameter: SimParameter) -> None:
        if not parameter.keys:
            return
        power_on = SIM_VALUES.get(parameter.name, 0)
        raw = int(round(Decimal(str(power_on)) * max(1, parameter.scale)))
        access = {'rw': 'rw', 'ro': 'ro', 'wo': 'wo'}[parameter.access]
        if len(parameter.keys) == 2:  # 64-bit over two UNSIGNED32
            for k, part in zip(parameter.keys, (raw & 0xFFFFFFFF, raw >> 32)):
                _ensure(self.store, _variable(parameter.name, k >> 8, k & 0xFF, dt.UNSIGNED32, access, part))
            return
        k = parameter.keys[0]
        _ensure(self.store, _variable(parameter.name, k >> 8, k & 0xFF, _TYPES[parameter.kind], access, raw))

    # -- SDO side (called with the slave's lock held) ---------------------------------------------------
    def _check_chunk(self, value: Any) -> None:
        if not isinstance(value, str) or len(value) > CHUNK:
            raise SdoAbortedError(ABORT_TOO_LONG)

    def _on_chunk(self, value: str) -> None:
        if not self._buffer:
            self._reply = ''  # a new command: what is left of the last reply is gone
        self._buffer += value
        while TERMINATOR in self._buffer:
            command, self._buffer = self._buffer.split(TERMINATOR, 1)
            self._reply = self._respond(self.execute(command))
        if len(self._buffer) > MAX_COMMAND:
            self._buffer = ''
            self._reply = self._respond('Error: Command too long')

    def _next_chunk(self) -> str:
        chunk, self._reply = self._reply[:CHUNK], self._reply[CHUNK:]
        return chunk

    @staticmethod
    def _respond(output: str) -> str:
        return '>' + (output + '\n' if output else '') + TERMINATOR

    # -- the drive's command interpreter ---------------------------------------------------------------
    def execute(self, command: str) -> str:
        """The output of one command line (without prompt and terminator)."""
        text = command.strip()
        self.commands.append(text)
        if not text:
            return ''
        name, _, argument = text.partition(' ')
        name, argument = name.upper(), argument.strip()
        parameter = PARAMETERS.get(name)
        if parameter is None:
            return 'Error: Unknown command'
        if name in _CONTROL_COMMANDS and getattr(self.slave, 'remote', False):
            return 'Error: Drive is controlled by the fieldbus (FBUS.REMOTE = 1)'
        if parameter.kind == 'cmd':
            return 'Error: Command takes no argument' if argument else self._run(name)
        if not argument:
            if parameter.access == 'wo':
                return 'Error: Parameter is write-only'
            return self._show(parameter)
        if parameter.access == 'ro':
            return 'Error: Parameter is read-only'
        return self._set(parameter, argument)

    def _run(self, name: str) -> str:
        if name == 'DRV.NVSAVE':
            if self._save is not None:
                self._save()
            else:
                for k in self.store.variables:
                    self.store.defaults[k] = self.store.values[k]
        return ''

    def _raw(self, parameter: SimParameter) -> int:
        values = [int(self.store.get(k)) for k in parameter.keys]
        return values[0] | values[1] << 32 if len(values) == 2 else values[0]

    def _show(self, parameter: SimParameter) -> str:
        if parameter.name == 'DRV.FAULTS':
            codes = list(self.slave.emcy.active_codes)
            return '\n'.join(f'Fault: EMCY 0x{code:04X}' for code in codes) if codes else 'No faults active'
        if parameter.name == 'FBUS.REMOTE':
            return str(int(bool(getattr(self.slave, 'remote', True))))
        raw = self._raw(parameter)
        text = f'{Decimal(raw) / parameter.scale:.3f}' if parameter.scale > 0 else str(raw)
        return f'{text} [{parameter.unit}]' if parameter.unit else text

    def _set(self, parameter: SimParameter, argument: str) -> str:
        try:
            value = Decimal(argument) if _NUMBER.fullmatch(argument) else None
        except InvalidOperation:
            value = None
        if value is None or parameter.kind not in _RANGES:
            return 'Error: Invalid argument'
        raw = int((value * max(1, parameter.scale)).to_integral_value())
        low, high = _RANGES[parameter.kind]
        scale = max(1, parameter.scale)
        if raw > high:
            return f'Error: Argument above maximum ({Decimal(high) / scale})'
        if raw < low:
            return f'Error: Argument below minimum ({Decimal(low) / scale})'
        if parameter.choices and raw not in parameter.choices:
            return f'Error: Invalid value (allowed: {", ".join(map(str, parameter.choices))})'
        if parameter.name == 'FBUS.REMOTE':
            self.slave.set_remote(bool(raw))
            return ''
        if len(parameter.keys) == 2:
            self.store.values[parameter.keys[0]] = raw & 0xFFFFFFFF
            self.store.values[parameter.keys[1]] = raw >> 32
        elif parameter.keys:
            self.store.values[parameter.keys[0]] = raw
        return ''
