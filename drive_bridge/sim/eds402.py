"""A generic simulated CiA 402 drive faithful to the EDS it is built from: the objects, PDO
capacities and mappability come from the EDS (the object store and PDO engine take them as
they are); the modes are the EDS's 0x6502, and where the EDS gives 0x6502 no value (or has
none), the modes its objects allow (:func:`drive_bridge.families.generic402.modes.inferred_support`).

A limit the file gives as 0 or not at all (a following error window, a maximum speed, torque
or acceleration) is the drive's own setting the file leaves open: no drive moves with a zero
limit, and vendor tools fill these in from the drive. The simulator then takes the limit as
not limiting (the data type's maximum; 0x6065 = 0xFFFFFFFF: following control off).

A device type (0x1000) the file gives no value is a CiA 402 servo drive's, 0x00020192 (profile
402, type 2), as maxon's EPOS4 reports with an EDS that leaves it open: a drive answers it."""
from __future__ import annotations

from canopen.objectdictionary import datatypes as dt

from drive_bridge.cia402 import objects as obj
from drive_bridge.families.generic402.modes import declared_support, has_supported_modes, inferred_support
from drive_bridge.sim.drive402 import SimDrive402
from drive_bridge.sim.store import key

DEVICE_TYPE = 0x1000
SERVO_DRIVE_402 = 0x00020192  # CiA 402: profile 402 in bits 0-15, drive type 2 (servo) in bits 16-23
OPEN_LIMITS = (obj.FOLLOWING_ERROR_WINDOW, obj.MAX_TORQUE, obj.MAX_PROFILE_VELOCITY, obj.MAX_MOTOR_SPEED,
               obj.PROFILE_VELOCITY, obj.PROFILE_ACCELERATION, obj.PROFILE_DECELERATION,
               obj.QUICK_STOP_DECELERATION, obj.MAX_ACCELERATION, obj.MAX_DECELERATION)


class EdsDrive402(SimDrive402):
    """The simulator of family ``generic_402``."""

    def on_axes_created(self) -> None:
        od, store = self.store.od, self.store
        device_type = store.variables.get(key(DEVICE_TYPE, 0))
        if device_type is not None and device_type.value is None and device_type.default is None:
            store.set_default(DEVICE_TYPE, 0, SERVO_DRIVE_402)
        for axis in self.axes:
            for index in OPEN_LIMITS:
                k = key(obj.for_axis(index, axis.slot), 0)
                var = store.variables.get(k)
                if var is not None and store.defaults[k] == 0 and var.data_type in dt.INTEGER_TYPES:
                    bits = len(var)
                    top = (1 << (bits - 1)) - 1 if var.data_type in dt.SIGNED_TYPES else (1 << bits) - 1
                    store.set_default(var.index, 0, top)
            if declared_support(od, axis.slot) is not None:
                continue
            modes = inferred_support(od, axis.slot)
            if has_supported_modes(od, axis.slot):  # no DefaultValue: the drive reports what it has
                store.set_default(obj.for_axis(obj.SUPPORTED_DRIVE_MODES, axis.slot), 0, modes)
            else:
                axis.declared_modes = modes
        for axis in self.axes:
            axis.invalidate_parameters()
