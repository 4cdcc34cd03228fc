"""Indices, codes, tables and units of the simulated SERVOSTAR 400/600
(shared/drives/servostar-400-600.md; numbers in brackets are its sections)."""
from __future__ import annotations

# -- communication and manufacturer objects --------------------------------------------------------
STATUS_REGISTER = 0x1002  # DRVSTAT [3.5]
STORE_PARAMETERS = 0x1010  # sub 2: save communication parameters (DRVCNFG bit 3) [2.5]
SIGNATURE_SAVE = 0x65766173  # "save"
CHANGE_MASKS = 0x2014  # + channel - 1 [2.5]
POSITION_CONTROLLER = 0x2020  # sub 2 PEINPOS, 3 PEMAX, 8 PGEARO, 9 PGEARI [6.3]
MOTION_TASK = 0x2022  # sub 1 position, 2 speed, 3 type, 4 trajectory setpoint, 5 task number [6.4]
HOMING_SETUP = 0x2024  # NREF, DREF, VREF, ACCR, DECR, ROFFS, VJOG [6.1]
SETPOINT = 0x2060  # digital speed (1875/262144 rpm) or current (3280 = peak) [6.7]
ACTUAL = 0x2070  # actual values [8.2]
STATUS_BYTES = 0x2080
POSITION_TRIGGER = 0x2086
RPDO_SELECT, TPDO_SELECT = 0x2600, 0x2A00  # + channel - 1 [2.5]
PDO33_HALF = 0x2721  # [5.1]
ASCII_RX, ASCII_TX = 0x3100, 0x3102  # PDO 21 characters [2.6, 2.7]

# object channel (sub 1 = value) [8.4]
VALUE = 1
ACC, DEC, DECSTOP = 0x3501, 0x3522, 0x3525  # ramp times, ms
ADDR, CBAUD = 0x3505, 0x3515
CLRFAULT, CLRWARN = 0x3518, 0x351B
DRVSTAT = 0x352D
OPMODE = 0x35B4
PEMAX = 0x35C7
PRBASE, PTBASE = 0x35D1, 0x35D5
SAVE, COLDSTART = 0x35EB, 0x3632
VLIM = 0x3622  # rpm
MDRV = 0x3639
DRVCNFG = 0x3672

# DRVCNFG bits [1.4]
DRVCNFG_BOOT_SHORT_BIT0 = 1 << 0  # §2.6: power-on telegram 0 bytes long
DRVCNFG_LENGTH_CHECK = 1 << 2  # object length check (§6.1.1 reads bit 2 as the boot telegram length)
DRVCNFG_STORE_PDOS = 1 << 3  # PDO configuration stored with 0x1010:2 and restored at power-on
DRVCNFG_STATUS_BIT11 = 1 << 20  # statusword bit 11 reports selected warnings

# -- profile objects -----------------------------------------------------------------------------------
INTERPOLATION_PERIOD = 0x60C2
POSITION_INCREMENTS = 0x6063  # 2^PRBASE per revolution
VELOCITY_FACTOR = 0x6094
POSITION_FACTOR = 0x6093

# -- SDO abort codes [2.4] -------------------------------------------------------------------------
ABORT_COMMAND = 0x05040001  # client/server command specifier not valid
ABORT_READ_ONLY = 0x06010002
ABORT_INVALID_VALUE = 0x06090030
ABORT_NOT_STORED = 0x08000020
ABORT_STATE = 0x08000022

# -- units [7] ------------------------------------------------------------------------------------------
COUNTS_PER_REV = 2 ** 20  # the model's position unit (the speed controller's resolution)
COUNTS_PER_S_PER_SPEED_BIT = 125.0  # 1875/262144 rpm = 2^-25 rev per 250 us
SAMPLE = 250e-6  # s: PTBASE unit, "increments per 250 us" speed unit
RATED_CURRENT_COUNTS = 1640  # 2060h in FD: 1640 = rated, 3280 = peak current
RATED_CURRENT_MA = 3000  # the simulated SD06's rated current (for 0x2070:09)

# -- modes [4.6] ---------------------------------------------------------------------------------------
POSITION, SPEED_DIGITAL, CURRENT_DIGITAL, SPEED_ANALOG, CURRENT_ANALOG = -1, -2, -3, -4, -5
TRAJECTORY, HOMING_MANUFACTURER, JOG, GEARING = -6, -7, -8, -9
PROFILE_POSITION, PROFILE_VELOCITY, HOMING = 1, 3, 6
MODES = frozenset({POSITION, SPEED_DIGITAL, CURRENT_DIGITAL, SPEED_ANALOG, CURRENT_ANALOG, TRAJECTORY,
                   HOMING_MANUFACTURER, JOG, GEARING, PROFILE_POSITION, PROFILE_VELOCITY, HOMING})
# OPMODE (35B4h, saved) -> the CANopen mode at power-on; a saved position mode comes up as homing [4.6]
POWER_ON_MODES = {0: SPEED_DIGITAL, 1: SPEED_ANALOG, 2: CURRENT_DIGITAL, 3: CURRENT_ANALOG, 4: GEARING,
                  8: HOMING_MANUFACTURER}
HOMING_METHODS = frozenset({-3, -2, -1, 1, 2, 8, 12, 17, 18, 24, 28, 33, 34, 35})  # 6098h [6.2]

# -- PDO library [2.6, 2.7] -------------------------------------------------------------------------
FREE_PDOS = frozenset({37, 38, 39, 40})
_ASCII_RX = tuple(ASCII_RX << 16 | k << 8 | 8 for k in range(1, 9))
_ASCII_TX = tuple(ASCII_TX << 16 | k << 8 | 8 for k in range(1, 9))
RPDO_LIBRARY: dict[int, tuple[int, ...]] = {
    0: (),
    1: (0x60400010,),
    21: _ASCII_RX,
    22: (0x60400010, 0x20600020),
    32: (0x20600020,),
    33: (0x20220420, 0x20220420),
    34: (0x20220120, 0x20220210, 0x20220310),
    35: (0x20220510,),
    41: (0x20220420,),
}
TPDO_LIBRARY: dict[int, tuple[int, ...]] = {
    0: (),
    1: (0x60410010,),
    21: _ASCII_TX,
    22: (0x60410010, 0x20700118, 0x20700218),
    23: (0x60410010, 0x10020020),
    32: (0x20700118, 0x20700218),
    33: (0x20700320, 0x20701120),
    34: (0x20860010,),
    41: (0x20701320,),
}
ASCII_PDO = 21
TRAJECTORY_PDO = 33
MOTION_TASK_PDO = 34
# transmission types a library PDO accepts (others: 0..240 and 254/255 as CiA 301)
ONLY_ASYNC = 255
RPDO_ONLY_ASYNC = frozenset({21, 34, 35})
TPDO_ONLY_ASYNC = frozenset({21})
RPDO_ONLY_SYNC = frozenset({33})
TPDO_ONLY_SYNC = frozenset({32, 33})

# -- EMCY [3.1, 3.2] ------------------------------------------------------------------------------------
EMCY_BOOT = 0x0000
EMCY_NOT_READY = 0x1080
EMCY_FEEDBACK = 0x7303
EMCY_NOT_ENABLED = 0x7181
EMCY_ONLY_DISABLED = 0x7182
EMCY_RESPONSE_MONITORING = 0x8181
EMCY_NOT_OPERATION_ENABLE = 0x8281
EMCY_WRONG_MODE = 0x8282
EMCY_FOLLOWING_ERROR = 0x8611
EMCY_TASK_NUMBER = 0x8681
EMCY_TRAJECTORY = 0x8682
EMCY_PDO_ELEMENT = 0xFF02
CATEGORIES: dict[int, int] = {
    0x1080: 5, 0x2330: 2, 0x3100: 1, 0x3110: 1, 0x3120: 1, 0x3130: 1, 0x4110: 1, 0x4210: 1, 0x4310: 1,
    0x5111: 1, 0x5380: 1, 0x5400: 1, 0x5420: 1, 0x5441: 1, 0x5530: 1, 0x5581: 1, 0x6010: 4, 0x6181: 4,
    0x6182: 4, 0x6183: 4, 0x6184: 4, 0x6185: 4, 0x6281: 4, 0x6282: 4, 0x6320: 3, 0x7111: 1, 0x7122: 1,
    0x7181: 5, 0x7182: 5, 0x7303: 1, 0x8053: 1, 0x8181: 2, 0x8182: 1, 0x8281: 5, 0x8282: 5, 0x8331: 1,
    0x8480: 1, 0x8611: 2, 0x8681: 5, 0x8682: 2, 0xFF01: 4, 0xFF02: 3, 0xFF03: 5, 0xFF04: 1, 0xFF06: 2,
    0xFF07: 2, 0xFF08: 2, 0xFF10: 1, 0xFF11: 1,
}
# EMCY code -> front-panel fault Fxx (bit xx-1 of ERRCODE 0x2070:16) [3.2, 3.6]
FAULT_NUMBERS: dict[int, int] = {
    0x2330: 22, 0x3100: 16, 0x3110: 2, 0x3120: 5, 0x3130: 19, 0x4110: 13, 0x4210: 1, 0x4310: 6,
    0x5111: 7, 0x5380: 17, 0x5400: 14, 0x5420: 18, 0x5441: 27, 0x5530: 9, 0x5581: 10, 0x6010: 32,
    0x6281: 32, 0x6282: 32, 0x7111: 11, 0x7122: 25, 0x7303: 4, 0x8053: 21, 0x8182: 23, 0x8331: 15,
    0x8480: 8, 0x8611: 3, 0x8682: 28, 0xFF01: 32, 0xFF04: 20, 0xFF06: 24, 0xFF07: 26, 0xFF08: 29,
    0xFF10: 12,
}

# -- 0x1002 manufacturer status register bits [3.5] ---------------------------------------------
WARN_FOLLOWING_ERROR = 1 << 2  # n03
WARN_RESPONSE_MONITORING = 1 << 3  # n04
INTERNAL_LIMIT_WARNINGS = (1 << 3 | 1 << 5 | 1 << 6 | 1 << 8 | 1 << 9 | 1 << 10 | 1 << 12)  # n04 n06 n07 n09-n11 n13
ST_TASK_ACTIVE = 1 << 16
ST_REFERENCE_SET = 1 << 17
ST_HOME_POSITION = 1 << 18
ST_IN_POSITION = 1 << 19
ST_INIT_DONE = 1 << 26
ST_STANDSTILL = 1 << 28
ST_STAGE_ENABLED = 1 << 30
ST_ERROR = 1 << 31

# statusword bits the SERVOSTAR uses its own way [4.5]
SW_VOLTAGE_DISABLE = 1 << 4  # 0 = DC link present
SW_TOGGLE = 1 << 8  # toggles at every completed motion task / pp target
SW_REMOTE = 1 << 9  # not supported: always 0
SW_INTERNAL_LIMIT = 1 << 11
SW_FAULT = 1 << 3

# controlword manufacturer bits [4.4]
CW_ACKNOWLEDGE = 1 << 11  # following error and response monitoring (category 2)
CW_SET_REFERENCE = 1 << 12
