"""The AKD's object indices, EMCY codes, abort codes and fixed values used by its simulator
(manual sections in brackets, as in the package docstring)."""
from __future__ import annotations

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode

ABORT_INVALID_VALUE = 0x06090030
ABORT_STATE = 0x08000022  # "PDO mapping must be done before NMT start"
ABORT_NOT_STORED = 0x08000020

EMCY_PVT_OVERFLOW = 0x8584  # n704
EMCY_PVT_UNDERFLOW = 0x8585  # n705
EMCY_SYNC_LOST = 0x8780  # F125
CATEGORY = b'\x01'  # EMCY byte 3 in error and warning frames [2.6]

PVT = -2  # 0x60C0 sub-modes
LINEAR = 0
MODES = frozenset({Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE, Mode.HOMING,
                   Mode.INTERPOLATED_POSITION, Mode.CYCLIC_SYNC_POSITION})  # 0x6060 accepts these [4.6]
HOMING_METHODS = frozenset({1, 2, 8, 12, 17, 18, 24, 28, 33, 34, 35})
# the AKD has no option codes 0x605A..0x605E; its fixed behaviour in CiA terms [4.4]
FIXED_OPTION_CODES = {obj.QUICK_STOP_OPTION: 6, obj.SHUTDOWN_OPTION: 0, obj.DISABLE_OPERATION_OPTION: 1,
                      obj.HALT_OPTION: 1, obj.FAULT_REACTION_OPTION: 2}

MANUFACTURER_STATUS = 0x1002
STORE_PARAMETERS = 0x1010
RESTORE_PARAMETERS = 0x1011
CHANGE_MASKS = 0x2014  # TPDO1; 0x2015..0x2017 for TPDO2..4
PV_SCALING = 0x204C
CS_DEC = 0x3440
DRV_ACC = 0x3501
DRV_DEC = 0x3522
IN_POSITION_WINDOW = 0x35C6  # MT.TPOSWND
SYNC_SUPERVISION = 0x36E8  # FBUS.PARAM04
POSITION_INCREMENTS = 0x6063
POSITION_WINDOW = 0x6067
ENCODER_RESOLUTION = 0x608F
SIGNATURE_SAVE = 0x65766173  # "save"
SIGNATURE_LOAD = 0x64616F6C  # "load"
