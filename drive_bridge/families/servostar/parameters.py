"""SERVOSTAR parameters by their ASCII names (``PTBASE``, ``VLIM``, ``PEMAX``, ...) through the
object channel 0x3500+ (shared/drives/servostar-400-600.md §8.3, §8.4).

Every ASCII parameter or command whose value fits in four bytes is an object of its own, with
eight sub-indices: 1 the value (writing it executes a command), 2 lower limit, 3 upper limit,
4 default, 5 format, 6 control flags (0x00010000: takes effect after SAVE and a restart,
0x00020000: kept in the EEPROM, 0x00200000: read-only over the bus). The drive answers SDO
expedited only, so every value is one round trip.

The table (:data:`CHANNEL_TABLE`) is the manual's object-channel list (§8.4: index, name, data
format, weighting, when the command is accepted, EEPROM); the node's EDS wins where it lists
the object (its data type and access). A name outside the table is refused, with the closest
known names suggested, so a typo never reaches the drive.

- read: sub 1 (and, where the drive has them, subs 2/3 for the range and 6 for the flags);
  a command (no data format) cannot be read;
- write: checked against the data type's range, the drive's own limits (subs 2/3, when
  upper > lower) and read-only flags before anything is sent, then read back; a command is
  executed by writing 0 (any value the caller gives is refused);
- save: the command SAVE (0x35EB:01 = 0). Parameters marked "Reset" take effect only after
  SAVE and a restart (COLDSTART 0x3632 or power).
"""
from __future__ import annotations

import difflib
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Final

from canopen import ObjectDictionary
from canopen.objectdictionary import ODRecord, ODVariable, datatypes as dt

from drive_bridge.families.errors import ParameterError
from drive_bridge.families.parameters import (
    ParameterAccess,
    ParameterPort,
    ParameterValue,
    format_limit,
    parameter_error,
)
from drive_bridge.families.servostar import objects as o

FLAG_RESTART: Final = 0x00010000
FLAG_EEPROM: Final = 0x00020000
FLAG_READ_ONLY: Final = 0x00200000
KINDS: Final = {'i8': (1, True), 'i16': (2, True), 'i32': (4, True), 'u8': (1, False), 'u16': (2, False),
                'u32': (4, False)}
_EDS_KINDS: Final = {dt.INTEGER8: 'i8', dt.INTEGER16: 'i16', dt.INTEGER32: 'i32', dt.UNSIGNED8: 'u8',
                     dt.UNSIGNED16: 'u16', dt.UNSIGNED32: 'u32'}

# index name format weighting status eeprom  (the manual's §8.4, '-' = empty cell)
CHANNEL_TABLE: Final = """\
3500 MAXSDO i32 - - -
3501 ACC i16 - - eeprom
3502 ACCR i16 - - eeprom
3503 ACTFAULT i8 - disabled+reset eeprom
3504 ACTIVE i8 - - ram
3505 ADDR u8 - - eeprom
3506 AENA i8 - - eeprom
3507 ANCNFG i8 - disabled+reset eeprom
3508 ANDB i32 w - eeprom
3509 ANIN1 i32 - - ram
350A ANIN2 i32 - - ram
350B ANOFF1 i16 - - eeprom
350C ANOFF2 i16 - - eeprom
350D ANOUT1 i8 - disabled+reset eeprom
350E ANOUT2 i8 - disabled+reset eeprom
350F ANZERO1 - - - -
3510 ANZERO2 - - - -
3511 AVZ1 i32 w - eeprom
3512 CALCHP - - enabled -
3513 CALCRK - - enabled -
3514 CALCRP - - disabled+reset -
3515 CBAUD i16 - disabled+reset eeprom
3517 CDUMP - - - -
3518 CLRFAULT - - - -
3519 CLRHR - - - -
351A CLRORDER i16 - disabled -
351B CLRWARN u8 - disabled+reset eeprom
351C CONFIG - - - -
351D CONTINUE - - enabled -
351E CTUNE - - enabled -
351F CUPDATE - - disabled -
3520 DAOFFSET1 i16 - - eeprom
3521 DAOFFSET2 i16 - - eeprom
3522 DEC i16 - - eeprom
3523 DECDIS i16 - - eeprom
3524 DECR i16 - - eeprom
3525 DECSTOP i16 - - eeprom
3526 DEVICE - - - ram
3527 DICONT i32 w - ram
3528 DIFVAR - - - -
3529 DIPEAK i32 w - ram
352A DIR i8 - disabled+reset eeprom
352B DIS - - enabled -
352C DREF i8 - - eeprom
352D DRVSTAT i32 - - ram
352E DR_TYPE i16 - - ram
352F DUMP - - - -
3530 EN - - disabled -
3531 ENCCAPT i8 - disabled eeprom
3532 ENCIN i32 - disabled+reset eeprom
3533 ENCLINES i16 - disabled+reset eeprom
3534 ENCMODE i8 - - eeprom
3535 ENCOUT i16 - - eeprom
3537 ENCZERO i16 - - eeprom
3538 EXTMUL i16 - - eeprom
3539 EXTPOS i8 - disabled+reset eeprom
353A EXTWD i32 - - eeprom
353B FBTYPE i8 - disabled+reset eeprom
353C FILTMODE u8 - disabled+reset eeprom
353D FOLDMODE i8 - disabled+reset eeprom
353E GEARI i16 - - eeprom
353F GEARMODE i8 - disabled+reset eeprom
3540 GEARO i16 - - eeprom
3541 GET - - - -
3542 GP i32 w - eeprom
3543 GPFBT i32 w - eeprom
3544 GPFFT i32 w - eeprom
3545 GPFFV i32 w - eeprom
3546 GPTN i32 w - eeprom
3547 GPV i32 w - eeprom
3548 GV i32 w - eeprom
3549 GVFBT i32 w - eeprom
354A GVFILT i8 - - eeprom
354B GVFR i32 w - eeprom
354C GVT2 i32 w - eeprom
354D GVTN i32 w - eeprom
354E HACOFFS i16 - - encoder
354F HAFACT1 i16 - - encoder
3550 HASOFFS i16 - - encoder
3551 HDUMP - - - -
3552 HICOFFS i16 - - eeprom
3553 HIFACT1 i16 - - encoder
3554 HISOFFS i16 - - encoder
3555 HRESET - - - -
3556 HSAVE - - - -
3557 HVER - - - ram
3558 I i32 w - ram
3559 I2T i32 - - ram
355A I2TLIM i8 - - eeprom
355B ICMD i32 w - ram
355C ICONT i32 w - eeprom
355D ID i32 w - ram
355E IDUMP - - - -
355F IMAX i32 w - ram
3560 IN - - - -
3561 IN1 i8 - - -
3562 IN1MODE i8 - disabled+reset eeprom
3563 IN1TRIG i32 - - eeprom
3564 IN2 i8 - - ram
3565 IN2MODE i8 - disabled+reset eeprom
3566 IN2TRIG i32 - - eeprom
3567 IN3 i8 - - ram
3568 IN3MODE i8 - disabled+reset eeprom
3569 IN3TRIG i32 - - eeprom
356A IN4 i8 - - ram
356B IN4MODE i8 - disabled+reset eeprom
356C IN4TRIG i32 - - eeprom
356D INPOS - - - -
356E IPEAK i32 w - eeprom
356F IPEAKN i32 w - eeprom
3570 IQ i32 w - ram
3571 ISCALE1 i32 w - eeprom
3572 ISCALE2 i32 w - eeprom
3573 K - - enabled ram
3574 KC i32 w - eeprom
3575 KEYLOCK i8 - - eeprom
3577 L i32 w - eeprom
3578 LATCH16 i16 - - -
3579 LATCH16N i16 - - ram
357A LATCH32 i32 - - -
357B LATCH32N i32 - - ram
357C LATCHX32 i32 - - ram
357D LATCHX32N i32 - - ram
357E LED1 i8 - - -
357F LED2 i8 - - -
3580 LED3 i8 - - -
3581 LEDSTAT i16 - - -
3582 LIST - - - ram
3583 LOAD - - - ram
3584 MAXTEMPE i16 - - eeprom
3585 MAXTEMPH i16 - - eeprom
3586 MAXTEMPM i32 w - eeprom
3587 MBRAKE i8 - disabled+reset eeprom
3588 MDBCNT - - - -
3589 MDBGET - - - -
358A MDBSET i16 - - -
358B MDUMP - - - -
358D MH - - enabled -
358E MICONT i32 w - eeprom
358F MIPEAK i32 w - eeprom
3591 MJOG - - enabled -
3592 MVANGLP i16 - - eeprom
3593 MKT i32 w - eeprom
3595 MLGC i32 w - eeprom
3596 MLGD i32 w - eeprom
3597 MLGP i32 w - eeprom
3598 MLGQ i32 w - eeprom
3599 MNUMBER i16 - disabled eeprom
359A MONITOR1 i16 - - ram
359B MONITOR2 i16 - - ram
359C MPHASE i16 - disabled eeprom
359D MPOLES i8 - disabled eeprom
359E MRD - - enabled -
35A0 MRESBW i16 - - eeprom
35A1 MRESPOLES i8 - disabled eeprom
35A2 MSG i8 - - eeprom
35A3 MSPEED i32 w - eeprom
35A5 MTANGLP i16 - - eeprom
35A7 MVANGLB i32 - - eeprom
35A8 MVANGLF i16 - - eeprom
35A9 M_RESET - - disabled -
35AA NONBTB i8 - - eeprom
35AB NOTCHBW i32 w - eeprom
35AC NOTCHHZ i32 w - eeprom
35AD NREF i8 - - eeprom
35AE O1 i8 - - ram
35AF O1MODE i8 - disabled+reset eeprom
35B0 O1TRIG i32 - - eeprom
35B1 O2 i8 - - ram
35B2 O2MODE i8 - disabled+reset eeprom
35B3 O2TRIG i32 - - eeprom
35B4 OPMODE i8 - - eeprom
35B5 OPTION i16 - - ram
35B6 OVRIDE i8 - - eeprom
35B7 O_ACC1 i16 - - ram
35B8 O_ACC2 i16 - - ram
35B9 O_C i16 - - ram
35BA O_DEC1 i16 - - ram
35BB O_DEC2 i16 - - ram
35BC O_FN i16 - - ram
35BD O_FT i16 - - ram
35BE O_P i32 - - ram
35BF O_V i32 - - ram
35C0 PBAL i32 - - ram
35C1 PBALMAX i32 - - eeprom
35C2 PBALRES i8 - - eeprom
35C3 PBAUD i32 w - ram
35C4 PDUMP - - - -
35C5 PE i32 - - ram
35C6 PEINPOS i32 - - eeprom
35C7 PEMAX i32 - - eeprom
35C8 PFB i32 - - ram
35C9 PFB0 i32 - - ram
35CA PGEARI i32 - disabled+reset eeprom
35CB PGEARO i32 - disabled+reset eeprom
35CC PIOBUF - - - ram
35CD PMODE i32 - disabled+reset eeprom
35CE PNOID i32 - - ram
35CF POSCNFG i8 - disabled+reset eeprom
35D0 PPOTYP i8 - - eeprom
35D1 PRBASE i8 - disabled+reset eeprom
35D2 PRD i32 - - ram
35D3 PROMPT i16 - - ram
35D4 PSTATE - - - ram
35D5 PTBASE i8 - - eeprom
35D6 PTMIN i16 - - eeprom
35D7 PV i32 - - ram
35D8 PVMAX i32 - - eeprom
35D9 PVMAXN i32 - - eeprom
35DC READNIMP - - - -
35DD READY i8 - - ram
35DE RECDONE i8 - - ram
35DF RECING i8 - - ram
35E0 RECOFF - - - -
35E1 RECRDY i8 - - ram
35E2 REFIP i32 w - eeprom
35E3 REFPOS i32 - - ram
35E4 REMOTE i8 - - ram
35E5 RESPHASE i16 - - eeprom
35E6 RK i16 - - eeprom
35E7 ROFFS i32 - - eeprom
35E8 RS232T i16 - - eeprom
35E9 RSTVAR - - disabled ram
35EA S - - - -
35EB SAVE - - - -
35EC SBAUD i8 - - eeprom
35ED SCAN - - - -
35EE SDUMP - - - -
35EF SERIALNO i32 - - ram
35F0 SETREF - - - -
35F1 SETROFFS - - - -
35F2 SLEN i8 - - eeprom
35F3 SLOTIO i32 - - ram
35F4 SPHAS i8 - - ram
35F5 SPSET i16 - - eeprom
35F6 SSIGRAY i8 - disabled eeprom
35F7 SSIINV i8 - disabled eeprom
35F8 SSIMODE i8 - - eeprom
35F9 SSIOUT i8 - disabled eeprom
35FA SSTAT - - - ram
35FB STAT i16 - - ram
35FC STATIO - - - ram
35FD STATUS - - - ram
35FE STOP - - enabled -
35FF STOPMODE i8 - disabled+reset eeprom
3600 SWCNFG u16 - disabled+reset eeprom
3601 SWCNFG2 u16 - disabled+reset eeprom
3602 SWE0 i32 - - eeprom
3603 SWE0N i32 - - eeprom
3604 SWE1 i32 - - eeprom
3605 SWE1N i32 - - eeprom
3606 SWE2 i32 - - eeprom
3607 SWE2N i32 - - eeprom
3608 SWE3 i32 - - eeprom
3609 SWE3N i32 - - eeprom
360A SWE4 i32 - - eeprom
360B SWE4N i32 - - eeprom
360C SWE5 i32 - - eeprom
360D SWE5N i32 - - eeprom
360E T i32 w enabled -
360F TASK - - - ram
3610 TEMPE i32 - - ram
3611 TEMPH i32 - - ram
3612 TEMPM i32 - - ram
3613 TRJSTAT i32 - - ram
3614 TRUN - - - eeprom
3616 UID i16 - - eeprom
3617 UVLTMODE i8 - disabled+reset eeprom
3618 V i32 - - ram
361A VBUS i32 - - ram
361B VBUSBAL i16 - - eeprom
361C VBUSMAX i32 - - eeprom
361D VBUSMIN i16 - - eeprom
361E VCMD i32 w - ram
361F VDUMP - - - -
3620 VELO i32 w - eeprom
3621 VJOG i32 - - eeprom
3622 VLIM i32 w - eeprom
3623 VLIMN i32 w - eeprom
3624 VMAX i32 w - ram
3625 VMIX i32 w - eeprom
3626 VMUL i32 - - eeprom
3627 VOSPD i32 w - eeprom
3628 VREF i32 - - eeprom
3629 VSCALE1 i16 - - eeprom
362A VSCALE2 i16 - - eeprom
362C DILIM i8 - disabled+reset eeprom
362D DENA i8 - - eeprom
362E IN2PM i8 - - eeprom
362F KTN i32 w - eeprom
3630 INPT i16 - - eeprom
3631 UCOMP i32 - - eeprom
3632 COLDSTART - - disabled -
3634 UID1 i32 - - eeprom
3635 SETVCT i16 - - ram
3636 WPOS i8 - disabled+reset ram
3637 SRND i32 - - eeprom
3638 ERND i32 - - eeprom
3639 MDRV i8 - - eeprom
363A BCC i16 - - ram
363B FPGA i8 - disabled+reset eeprom
363C REFMODE i8 - - eeprom
363D VLO i32 w - eeprom
363E WMASK i32 - - ram
363F WPOSE i32 - - ram
3640 WPOSP i32 - - ram
3641 WPOSX i32 - - ram
3642 MOVE i16 - enabled -
3643 POSRSTAT i32 - - ram
3644 P1 i32 - - eeprom
3645 P2 i32 - - eeprom
3646 P3 i32 - - eeprom
3647 P4 i32 - - eeprom
3648 P5 i32 - - eeprom
3649 P6 i32 - - eeprom
364A P7 i32 - - eeprom
364B P8 i32 - - eeprom
364C P9 i32 - - eeprom
364D P10 i32 - - eeprom
364E P11 i32 - - eeprom
364F P12 i32 - - eeprom
3650 P13 i32 - - eeprom
3651 P14 i32 - - eeprom
3652 P15 i32 - - eeprom
3653 P16 i32 - - eeprom
3654 PTARGET i32 - - eeprom
3655 ACTRS232 i8 - - ram
3656 ROFFS2 i32 - - eeprom
3657 FW i32 w - ram
3659 ACCUNIT i32 - - eeprom
365A VCOMM i32 - - eeprom
365B MTMUX i16 - - ram
365C ROFFS0 i32 - - eeprom
365D REFLS i32 - - eeprom
365E BOOT - - - eeprom
365F VUNIT i32 - - eeprom
3660 PUNIT i32 - - eeprom
366E TBRAKE i16 - - eeprom
366F TBRAKE0 i16 - - eeprom
3670 CMDDLY i16 - - eeprom
3672 DRVCNFG i32 - - eeprom
"""


@dataclass(frozen=True)
class ChannelParameter:
    """One object-channel entry: see the module docstring."""

    name: str
    index: int
    kind: str  # i8 .. u32, or 'cmd' (a command without data)
    weighted: bool  # the manual marks the value as weighted (scaled by the drive's units)
    status: str  # when the drive accepts it: '', 'enabled', 'disabled', 'disabled+reset'
    storage: str  # 'eeprom', 'ram', 'encoder' or ''
    access: str = 'rw'

    @property
    def is_command(self) -> bool:
        return self.kind == 'cmd'

    @property
    def limits(self) -> tuple[int, int] | None:
        if self.is_command:
            return None
        size, signed = KINDS[self.kind]
        return (-(1 << (8 * size - 1)), (1 << (8 * size - 1)) - 1) if signed else (0, (1 << (8 * size)) - 1)


def read_table(text: str = CHANNEL_TABLE) -> dict[str, ChannelParameter]:
    """Name (upper case) -> entry."""
    table: dict[str, ChannelParameter] = {}
    for line in text.splitlines():
        if not line.strip():
            continue
        index, name, kind, weighting, status, storage = line.split()
        table[name] = ChannelParameter(name, int(index, 16), 'cmd' if kind == '-' else kind, weighting == 'w',
                                       '' if status == '-' else status, '' if storage == '-' else storage)
    return table


TABLE: Final = read_table()


def _eds_entry(od: ObjectDictionary | None, index: int) -> ODVariable | None:
    if od is None or index not in od:
        return None
    entry = od[index]
    if isinstance(entry, ODRecord) and o.VALUE_SUB in entry:
        return entry[o.VALUE_SUB]
    return None


def _is_command_in_eds(od: ObjectDictionary, index: int) -> bool:
    entry = od[index]
    if isinstance(entry, ODRecord) and 5 in entry:
        return entry[5].default == 0
    return False


def lookup(name: str, port: ParameterPort, od: ObjectDictionary | None) -> ChannelParameter:
    """The entry of ``name`` (case-insensitive), with the EDS's type and access where it has one."""
    key = name.strip().upper()
    found = TABLE.get(key)
    if found is None:
        close = difflib.get_close_matches(key, TABLE, n=3)
        hint = f'; did you mean {", ".join(close)}?' if close else ''
        raise parameter_error(port, name, f'not an ASCII parameter of the object channel 0x3500+ (§8.4){hint}')
    var = _eds_entry(od, found.index)
    if var is None or od is None:
        return found
    kind = 'cmd' if _is_command_in_eds(od, found.index) else _EDS_KINDS.get(int(var.data_type or 0), found.kind)
    access = 'ro' if var.access_type in ('ro', 'const') else 'wo' if var.access_type == 'wo' else 'rw'
    return ChannelParameter(found.name, found.index, kind, found.weighted, found.status, found.storage, access)


def decode(data: bytes, kind: str) -> int:
    size, signed = KINDS[kind]
    return int.from_bytes(bytes(data[:size]).ljust(size, b'\0'), 'little', signed=signed)


def encode(value: int, kind: str) -> bytes:
    size, signed = KINDS[kind]
    return value.to_bytes(size, 'little', signed=signed)


# commands that store the parameters in the EEPROM or load them back (or the defaults)
STORE_COMMANDS: Final = frozenset({'SAVE', 'LOAD', 'RSTVAR'})
# the parameters that change the drive's link (node address, bit rate) or its master supervision
SAFETY_PARAMETERS = {'ADDR': 'ADDR, the CAN node address', 'CBAUD': 'CBAUD, the CAN bit rate'}


class ServostarParameters(ParameterAccess):
    """The object channel of one node (one instance per node; a lock serializes its calls)."""

    def __init__(self, port: ParameterPort, od: ObjectDictionary | None = None) -> None:
        self.port = port
        self.od = od
        self._lock = threading.Lock()

    # -- SDO ------------------------------------------------------------------------------------
    def _read_sub(self, entry: ChannelParameter, subindex: int, kind: str) -> int:
        try:
            return decode(self.port.sdo_read_raw(entry.index, subindex), kind)
        except ParameterError:
            raise
        except Exception as exc:
            raise parameter_error(self.port, entry.name, f'reading 0x{entry.index:04X}:{subindex:02X} failed: '
                                                         f'{exc}', drive_text=str(exc)) from exc

    def _optional(self, entry: ChannelParameter, subindex: int, kind: str) -> int | None:
        try:
            return decode(self.port.sdo_read_raw(entry.index, subindex), kind)
        except Exception:
            return None

    def _details(self, entry: ChannelParameter) -> tuple[float | None, float | None, int]:
        """(lower, upper, control flags) as the drive reports them (None / 0 where it does not)."""
        low = self._optional(entry, 2, entry.kind)
        high = self._optional(entry, 3, entry.kind)
        flags = self._optional(entry, 6, 'u32') or 0
        if low is None or high is None or high <= low:
            return None, None, flags
        return float(low), float(high), flags

    def _value(self, entry: ChannelParameter, raw: int, flags: int, low: float | None,
               high: float | None) -> ParameterValue:
        restart = bool(flags & FLAG_RESTART) or 'reset' in entry.status
        stored = bool(flags & FLAG_EEPROM) or entry.storage in ('eeprom', 'encoder')
        access = 'ro' if flags & FLAG_READ_ONLY else entry.access
        notes = [f'object 0x{entry.index:04X}:01']
        if restart:
            notes.append('takes effect after SAVE and a restart')
        if entry.status.startswith('disabled'):
            notes.append('written only with the output stage disabled')
        elif entry.status == 'enabled':
            notes.append('accepted only with the output stage enabled')
        if entry.weighted:
            notes.append("weighted: in the drive's own units")
        return ParameterValue(name=entry.name, value_text=str(raw), value=float(raw), unit='',
                              minimum=low, maximum=high, access=access, save_needed=stored or restart,
                              note='; '.join(notes))

    # -- ParameterAccess ---------------------------------------------------------------------------
    def read(self, name: str, drive_object: int = 0) -> ParameterValue:
        entry = lookup(name, self.port, self.od)
        if entry.is_command:
            raise parameter_error(self.port, entry.name, f'is a command without a value (0x{entry.index:04X}); '
                                                         'write it to execute it')
        if entry.access == 'wo':
            raise parameter_error(self.port, entry.name, 'is write-only')
        with self._lock:
            raw = self._read_sub(entry, o.VALUE_SUB, entry.kind)
            low, high, flags = self._details(entry)
        return self._value(entry, raw, flags, low, high)

    def write(self, name: str, value_text: str, drive_object: int = 0) -> ParameterValue:
        entry = lookup(name, self.port, self.od)
        if entry.is_command:
            if value_text.strip() not in ('', '0'):
                raise parameter_error(self.port, entry.name, f'is a command without a value: write it empty '
                                                             f'(or 0) to execute it, got {value_text!r}')
            with self._lock:
                self._write_raw(entry, encode(0, 'u32'))
            return ParameterValue(entry.name, 'executed', None, '', None, None, 'cmd', False,
                                  f'command 0x{entry.index:04X}:01 executed')
        if entry.access == 'ro':
            raise parameter_error(self.port, entry.name, 'is read-only')
        try:
            number = int(value_text.strip(), 0)
        except ValueError:
            raise parameter_error(self.port, entry.name, f'expected an integer, got {value_text!r}') from None
        limits = entry.limits
        assert limits is not None
        if not limits[0] <= number <= limits[1]:
            raise parameter_error(self.port, entry.name, f'{number} is outside {entry.kind.upper()} '
                                                         f'{limits[0]}..{limits[1]}')
        with self._lock:
            low, high, flags = self._details(entry)
            if flags & FLAG_READ_ONLY:
                raise parameter_error(self.port, entry.name, 'is read-only over the bus (control flags 0x00200000)')
            if low is not None and high is not None and not low <= number <= high:
                raise parameter_error(self.port, entry.name, f'{number} is outside the drive\'s range '
                                                             f'{format_limit(low)}..{format_limit(high)}')
            self._write_raw(entry, encode(number, entry.kind))
            raw = self._read_sub(entry, o.VALUE_SUB, entry.kind) if entry.access != 'wo' else number
        return self._value(entry, raw, flags, low, high)

    def _write_raw(self, entry: ChannelParameter, data: bytes) -> None:
        try:
            self.port.sdo_write_raw(entry.index, o.VALUE_SUB, data)
        except Exception as exc:
            raise parameter_error(self.port, entry.name, f'the drive refused 0x{entry.index:04X}:01: {exc}',
                                  drive_text=str(exc)) from exc

    def stores(self, name: str) -> bool:
        return name.strip().upper() in STORE_COMMANDS

    def safety(self, name: str) -> str | None:
        return SAFETY_PARAMETERS.get(name.strip().upper())

    def save(self, drive_object: int = 0) -> str:
        with self._lock:
            self._write_raw(TABLE['SAVE'], encode(0, 'u32'))
        return 'SAVE (0x35EB:01 = 0): parameters stored in the EEPROM'


def known_names() -> Mapping[str, ChannelParameter]:
    return TABLE
