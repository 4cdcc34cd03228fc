"""SINAMICS S120 (CBC10) object indices, per-drive-object offsets and the parameter numbers the
bridge uses (shared/drives/sinamics-s120-cbc10.md §1.4, §2.4, §3, §4.1).

One CANopen node (the Control Unit with its CBC10) carries up to 8 drive objects (DOs) as
logical devices: the DO in axis slot ``s`` (0-based; p8743[s] gives its DO number) has

- its CiA 402 objects at 0x6000..0x67FF + 0x800 * s (0x6040 -> 0x6840 for slot 1),
- its PDO parameters at 0x1400/0x1600/0x1800/0x1A00 + 0x40 * s, eight of each (the PDO
  numbers 64 * s + 1 .. 64 * s + 8),
- its free process-data objects at 0x5800 + 0x80 * s.

NMT, SYNC, EMCY, guarding and 0x1000..0x1029 belong to the whole node (the CU).
"""
from __future__ import annotations

MAX_DRIVE_OBJECTS = 8  # CiA 402 logical devices per node (§2.5)
PROFILE_OFFSET = 0x800  # CiA 402 objects per slot
PDO_OFFSET = 0x40  # PDO communication / mapping parameters per slot
PDO_NUMBERS_PER_SLOT = 64  # PDO numbering block per slot (Tab. 2-10)
PDOS_PER_SLOT = 8  # of which each DO has the first 8, each way
FREE_OFFSET = 0x80  # free process-data objects per slot
MAX_PDO_ENTRIES = 4  # mapped objects per PDO (8 bytes)
MAX_VALID_RPDOS = 25  # valid RPDOs of all DOs of one CU, a hardware limit (§2.7.3, A08758)
COB_ID_MAX = 0x6DF  # the highest COB-ID the drive takes (the V4.8 EDS: HighLimit 0x800006DF)

RPDO_COMM, RPDO_MAP, TPDO_COMM, TPDO_MAP = 0x1400, 0x1600, 0x1800, 0x1A00
FREE_OBJECTS = (0x5800, 0x587F)  # slot 0's range of free process-data objects
PROFILE_OBJECTS = (0x6000, 0x67FF)  # slot 0's range of CiA 402 objects

# -- CiA 301 objects of the node -------------------------------------------------------------------
ERROR_FIELD = 0x1003  # sub 0 = 0 acknowledges the faults of every DO of the CU (§6.3)
STORE_PARAMETERS = 0x1010
SAVE_SIGNATURE = 0x65766173  # "save"
# parameters that save or reset the parameters (p0977 = 0x1010 "save", p0976 = 0x1011 "load")
STORE_NUMBERS = frozenset({970, 971, 976, 977})  # reset DO, save DO, restore all, save all

# -- CiA 402 objects of slot 0 (+0x800 per slot) ---------------------------------------------------
ABORT_CONNECTION_OPTION = 0x6007  # = p8641 of the DO
VL_TARGET_VELOCITY = 0x6042  # r8792, INTEGER16, rpm: the set-point of velocity mode (vl)
POSITION_ACTUAL = 0x6063  # r0482: the S120 has no 0x6064
VELOCITY_ENCODER_FACTOR = 0x6094  # p8798: sub 1 numerator, sub 2 divisor

# -- the parameter window (§3) ---------------------------------------------------------------------
PARAMETER_BASE = 0x2000  # object = 0x2000 + parameter number (0..9999), sub-index = index % 256
PARAMETER_WINDOW = 10000  # numbers per range (p8630[2])
PAGE_SIZE = 256  # parameter indices per sub-index page (p8630[1])
MAX_PAGE = 3  # p8630[1]: 0..3 -> indices 0..1023
MAX_RANGE = 5  # p8630[2]: 0..5 -> numbers 0..59999
SELECTOR = 0x41B6  # p8630[0..2]: drive object, sub-index page, parameter range
SELECT_DO, SELECT_PAGE, SELECT_RANGE = 0, 1, 2
CU_DO = 1  # p8630[0] = 1: the Control Unit

# -- parameters the bridge reads at boot -----------------------------------------------------------
P_ENCODER_TYPE = 400  # p0400[0]: encoder type (0: no encoder)
P_CONTROL_MODE = 1300  # p1300 / r1300: 20/22 without encoder, 21/23 with (speed / torque control)
P_ENCODER_PULSES = 408  # p0408: encoder pulses per revolution (0: no encoder)
P_FINE_RESOLUTION = 418  # p0418: fine resolution, bits
R_RATED_TORQUE = 333  # r0333: rated motor torque, N·m (0x6071/0x6077 are per mille of it)
P_MAX_SPEED = 1082  # p1082: maximum speed, rpm
P_RAMP_DOWN = 1121  # p1121: ramp-down time, s
P_ABORT_CONNECTION = 8641  # p8641: drive reaction to a CAN communication error (0 = none)
P_NMT_AFTER_BOOT = 8684  # p8684: NMT state after start-up (4 stopped, 5 operational, 127 pre-op)
P_DO_OF_SLOT = 8743  # p8743[slot]: DO number of each axis slot
P_SAMPLING_TIME = 8848  # p8848: CAN (IF2 PZD) sampling time, ms


def profile_index(index: int, slot: int) -> int:
    """A CiA 402 object of slot 0 moved to ``slot``."""
    return index + PROFILE_OFFSET * slot


def pdo_number(slot: int, k: int) -> int:
    """The PDO number (1-based, as configured) of the ``k``-th (0..7) PDO of ``slot``."""
    return PDO_NUMBERS_PER_SLOT * slot + k + 1


def slot_of_pdo(number: int) -> tuple[int, int]:
    """(slot, k) of a PDO number: the DO block it is in and its place in the block."""
    return (number - 1) // PDO_NUMBERS_PER_SLOT, (number - 1) % PDO_NUMBERS_PER_SLOT


def shifted_index(index: int, slot: int) -> int:
    """An object of slot 0 moved to ``slot``: PDO parameters +0x40, free process data +0x80,
    CiA 402 objects +0x800 per slot; node objects stay where they are."""
    for base in (RPDO_COMM, RPDO_MAP, TPDO_COMM, TPDO_MAP):
        if base <= index < base + PDOS_PER_SLOT:
            return index + PDO_OFFSET * slot
    if FREE_OBJECTS[0] <= index <= FREE_OBJECTS[1]:
        return index + FREE_OFFSET * slot
    if PROFILE_OBJECTS[0] <= index <= PROFILE_OBJECTS[1]:
        return index + PROFILE_OFFSET * slot
    return index


def per_slot(index: int) -> bool:
    """The object (of slot 0) exists once per drive object."""
    return shifted_index(index, 1) != index
