"""Object indices, mode codes and bits of the SERVOSTAR 400/600 (shared/drives/servostar-400-600.md;
section numbers in brackets are that report's)."""
from __future__ import annotations

from typing import Final

# -- PDOs [2.5-2.8] ------------------------------------------------------------------------------
CHANNELS: Final = 4  # PDO channels per direction (0x1004 still reports 2 + 2)
RPDO_SELECT: Final = 0x2600  # + channel - 1: the library PDO number of an RPDO channel
TPDO_SELECT: Final = 0x2A00
RPDO_COMM: Final = 0x1400
TPDO_COMM: Final = 0x1800
FREE_PDOS: Final = (37, 38, 39, 40)  # library numbers whose mapping is written through 0x16xx / 0x1Axx
MAX_FREE_ENTRIES: Final = 8
PDO33_HALF: Final = 0x2721  # which half of RPDO 33 a drive takes (0: bytes 0-3)
COMM_SUBINDICES: Final = frozenset({1, 2, 3})  # COB-ID, transmission type, inhibit time (4: CMS, no 5)

# -- process data ------------------------------------------------------------------------------
CONTROLWORD: Final = 0x6040
STATUSWORD: Final = 0x6041
MODES_OF_OPERATION: Final = 0x6060  # write-only: an upload aborts 0x06010001
MODES_DISPLAY: Final = 0x6061
STATUS_REGISTER: Final = 0x1002  # manufacturer status register (DRVSTAT), UNSIGNED32
TRAJECTORY_SETPOINT: Final = (0x2022, 4)  # mode 0xFA: the absolute position setpoint of the next SYNC
ACTUAL_POSITION: Final = (0x2070, 3)  # incremental actual position, 2^PRBASE per motor revolution
ACTUAL_SPEED: Final = (0x2070, 2)  # INTEGER24, 1875/262144 rpm per bit
EXTENDED_STATUS: Final = (0x2070, 0x11)  # TPDO 33's status word (bit 31 error pending)
TORQUE_ACTUAL: Final = (0x6077, 0)  # per mille of the rated torque
TARGET_POSITION_PP: Final = (0x607A, 0)  # profile position, in user units (0x6093)
TARGET_VELOCITY: Final = (0x60FF, 0)  # profile velocity
POSITION_FACTOR: Final = 0x6093  # sub 1 numerator (increments), sub 2 feed constant (user units)
POSITION_CONTROLLER: Final = 0x2020  # sub 3 PEMAX (max following error, user units)

# -- the object channel (ASCII parameters, 0x3500+, sub 1 = value) [8.3, 8.4] ---------------------
VALUE_SUB: Final = 1
PRBASE: Final = 0x35D1  # position resolution, bits per motor revolution (16 or 20)
PTBASE: Final = 0x35D5  # trajectory period, 250 us units
VLIM: Final = 0x3622  # speed limit, rpm
PEMAX: Final = 0x35C7  # max following error (as 0x2020:03)
DEC: Final = 0x3522  # deceleration ramp, ms
DECSTOP: Final = 0x3525  # emergency ramp, ms
SAVE: Final = 0x35EB
COLDSTART: Final = 0x3632
PTBASE_UNIT: Final = 250e-6  # s

# -- modes of operation [4.6] -----------------------------------------------------------------------
MODE_POSITION: Final = -1  # 0xFF motion tasks
MODE_SPEED_DIGITAL: Final = -2  # 0xFE
MODE_CURRENT_DIGITAL: Final = -3  # 0xFD
MODE_TRAJECTORY: Final = -6  # 0xFA
MODE_HOMING_MANUFACTURER: Final = -7  # 0xF9
MODE_JOG: Final = -8  # 0xF8
MODE_PP: Final = 1
MODE_PV: Final = 3
MODE_HM: Final = 6
MODE_NAMES: Final = {  # the family's names for ~/set_mode, next to the numbers
    'trajectory': MODE_TRAJECTORY, 'fa': MODE_TRAJECTORY, 'position': MODE_POSITION, 'ff': MODE_POSITION,
    'speed_digital': MODE_SPEED_DIGITAL, 'fe': MODE_SPEED_DIGITAL,
    'current_digital': MODE_CURRENT_DIGITAL, 'fd': MODE_CURRENT_DIGITAL,
}

# -- control and status bits [4.4, 4.5, 3.5] --------------------------------------------------------
CW_RESET_FAULT: Final = 7  # category 1 (the drive restarts)
CW_ACKNOWLEDGE: Final = 11  # category 2: following error, response monitoring
DRVSTAT_ERROR_PENDING: Final = 1 << 31  # 0x1002 and 0x2070:11 bit 31
DRVSTAT_RESPONSE_MONITORING: Final = 1 << 3  # warning n04 (node guarding)
SPEED_RPM_PER_BIT: Final = 1875 / 262144
