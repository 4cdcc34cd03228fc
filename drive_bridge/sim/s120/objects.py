"""Indices, SINAMICS message numbers, EMCY codes, abort codes and fixed values of the simulated
SINAMICS S120 with CBC10 (sections of shared/drives/sinamics-s120-cbc10.md in brackets)."""
from __future__ import annotations

from drive_bridge.cia402.modes import Mode

CU = 1  # drive-object number of the Control Unit [3: p8630[0] = 1]
MAX_DRIVE_OBJECTS = 8  # [1.4]
PDO_BLOCK = 64  # PDO numbers per drive object (logical device) [1.4, Tab. 2-10]
PDOS_PER_DO = 8  # [2.4]
MAX_VALID_RPDOS = 25  # valid RPDOs over all drive objects, a hardware limit [2.4, §2.7.3]

# manufacturer area [3]
PARAMETER_BASE = 0x2000  # object = 0x2000 + parameter number
PARAMETER_LAST = 0x470F  # 0x2000 + 9999
PAGE_SIZE = 256  # sub-indices per p8630[1] page
RANGE_SIZE = 10000  # parameter numbers per p8630[2] range

# CiA 301 objects the simulator gives a meaning of its own
ERROR_HISTORY = 0x1003
STORE_PARAMETERS = 0x1010
RESTORE_PARAMETERS = 0x1011
ERROR_BEHAVIOUR = 0x1029  # sub 1 = p8609[0] (communication errors), sub 2 = p8609[1] (device errors)
CONSUMER_HEARTBEAT = 0x1016  # not in the object list [2.6]: removed if an EDS brings it
SIGNATURE_SAVE = 0x65766173  # "save" [8.6]
SIGNATURE_LOAD = 0x64616F6C  # "load"

# CiA 402 objects of the S120 that the generic axis does not know [4.1]
ABORT_CONNECTION_OPTION = 0x6007  # = p8641
VL_TARGET = 0x6042  # rpm, INTEGER16
VL_DEMAND = 0x6043
VL_ACTUAL = 0x6044
VL_MIN_MAX = 0x6046  # sub 1 p1080, sub 2 p1082 (rpm)
VL_ACCELERATION = 0x6048  # sub 1 delta speed p1082 (rpm), sub 2 delta time p1120 (s)
POSITION_ACTUAL = 0x6063  # = r0482: the S120 has no 0x6064 [4.1]
VELOCITY_SENSOR = 0x6069  # = r0061
TORQUE_DEMAND = 0x6074  # = r0079
SINGLE_DEVICE_TYPE = 0x67FF

# error register 0x1001 bits [2.7, Tab. 6-5]
REG_GENERIC = 1 << 0
REG_COMMUNICATION = 1 << 4
REG_MANUFACTURER = 1 << 7

# EMCY error codes [2.7, Tab. 6-4]
EMCY_DRIVE_FAULT = 0x1000  # every SINAMICS fault outside the cases below
EMCY_CAN_OTHER = 0x1001  # other CANopen messages F08700..F08799
EMCY_TELEGRAM_LOST = 0x8110  # A08751
EMCY_ERROR_PASSIVE = 0x8120  # A08752
EMCY_LIFE_GUARD = 0x8130  # F08700 (value 2)

# SINAMICS message numbers
F08700 = 8700  # CAN communication error (value 2: life guarding / too many lost telegrams)
A08751 = 8751  # telegram loss (receive cycle < 2 x p8848)
A08752 = 8752  # error passive
A08758 = 8758  # maximum number of valid PDOs exceeded
CAN_RANGE = range(8700, 8800)
COMMUNICATION_ERROR_VALUE = 2  # r0949 of F08700 after a life guarding event

CODES_BY_NUMBER = {A08751: EMCY_TELEGRAM_LOST, A08752: EMCY_ERROR_PASSIVE, F08700: EMCY_LIFE_GUARD}

# drive reactions of a fault (SINAMICS OFF1 / OFF2 / OFF3) as CiA 402 fault reaction option codes
# of the generic axis: 1 slow-down ramp (p1121), 0 coast (pulses off), 2 quick-stop ramp (p1135)
REACTIONS = {'OFF1': 1, 'OFF2': 0, 'OFF3': 2}
P8641_REACTIONS = {1: 'OFF1', 2: 'OFF2', 3: 'OFF3'}  # p8641: 0 = no reaction [6.5]

# NMT reaction p8609 / 0x1029 [6.5]
NMT_PRE_OPERATIONAL, NMT_NO_CHANGE, NMT_STOPPED = 0, 1, 2

MODES = frozenset({Mode.VELOCITY, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE})  # through 0x6060 [4.3]
P8684_STATES = (4, 5, 127)  # stopped, operational, pre-operational [2.1]

# abort codes (the manual has none [2.3]: CiA 301's)
ABORT_READ_ONLY = 0x06010002
ABORT_NOT_IN_OD = 0x06020000
ABORT_VALUE_RANGE = 0x06090030
ABORT_TOO_HIGH = 0x06090031
ABORT_TOO_LOW = 0x06090032
ABORT_NO_SUBINDEX = 0x06090011
ABORT_NOT_STORED = 0x08000020
ABORT_STATE = 0x08000022
ABORT_PDO_TOO_LONG = 0x06040042
