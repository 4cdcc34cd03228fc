"""The modes of operation a drive declares, and the ones the bridge can stream to it.

0x6502 says which modes a drive has, but many EDS files give it no default (the value is
read at boot) and some have no 0x6502 at all. Then the objects a mode needs tell:
profile position needs 0x607A, interpolated position 0x60C1 and 0x60C2, the cyclic
modes their target mapped in a PDO and the communication cycle (0x60C2), and so on."""
from __future__ import annotations

from collections.abc import Callable, Collection

from canopen import ObjectDictionary

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.bootmodes import STREAMING_ORDER
from drive_bridge.cia402.modes import SUPPORT_BITS, Mode
from drive_bridge.families.generic402.eds import ObjectKey, variable

# what a mode needs, besides controlword and statusword: (objects, target that must be mappable)
_NEEDS: dict[Mode, tuple[tuple[int, ...], int | None]] = {
    Mode.PROFILE_POSITION: ((obj.TARGET_POSITION,), None),
    Mode.PROFILE_VELOCITY: ((obj.TARGET_VELOCITY,), None),
    Mode.PROFILE_TORQUE: ((obj.TARGET_TORQUE,), None),
    Mode.HOMING: ((obj.HOMING_METHOD,), None),
    Mode.INTERPOLATED_POSITION: ((obj.INTERPOLATION_DATA_RECORD, obj.INTERPOLATION_TIME_PERIOD), None),
    Mode.CYCLIC_SYNC_POSITION: ((obj.TARGET_POSITION, obj.INTERPOLATION_TIME_PERIOD), obj.TARGET_POSITION),
    Mode.CYCLIC_SYNC_VELOCITY: ((obj.TARGET_VELOCITY, obj.INTERPOLATION_TIME_PERIOD), obj.TARGET_VELOCITY),
    Mode.CYCLIC_SYNC_TORQUE: ((obj.TARGET_TORQUE, obj.INTERPOLATION_TIME_PERIOD), obj.TARGET_TORQUE),
}

# what must be in an RPDO to stream in each of the bridge's streaming modes (None: may go by
# SDO; the bridge's position loop tolerates the delay); the order is cia402.bootmodes'
_STREAM_NEEDS: dict[int, ObjectKey | None] = {
    Mode.CYCLIC_SYNC_POSITION: (obj.TARGET_POSITION, 0),
    Mode.INTERPOLATED_POSITION: (obj.INTERPOLATION_DATA_RECORD, 1),
    Mode.PROFILE_VELOCITY: None,
}


def inferred_support(od: ObjectDictionary, slot: int) -> int:
    """0x6502 bits from the objects the EDS declares for axis ``slot`` (for a drive whose EDS
    gives no 0x6502 value)."""
    bits = 0
    for mode, (indices, mapped) in _NEEDS.items():
        keys = [(obj.for_axis(i, slot), 1 if i == obj.INTERPOLATION_DATA_RECORD else 0) for i in indices]
        if any(variable(od, k) is None for k in keys):
            continue
        target = variable(od, (obj.for_axis(mapped, slot), 0)) if mapped is not None else None
        if mapped is not None and (target is None or not target.pdo_mappable):
            continue
        bits |= 1 << SUPPORT_BITS[mode]
    return bits


def declared_support(od: ObjectDictionary, slot: int) -> int | None:
    """0x6502 as the EDS gives it (None: no default value, or no 0x6502)."""
    var = variable(od, (obj.for_axis(obj.SUPPORTED_DRIVE_MODES, slot), 0))
    value = None if var is None else (var.value if var.value is not None else var.default)
    return value if isinstance(value, int) else None


def has_supported_modes(od: ObjectDictionary, slot: int) -> bool:
    return variable(od, (obj.for_axis(obj.SUPPORTED_DRIVE_MODES, slot), 0)) is not None


def streamable(slot: int, in_rpdo: Callable[[ObjectKey], bool], exists: Collection[ObjectKey]) -> tuple[int, ...]:
    """The modes, best first, the bridge can stream with this map: CSP with 0x607A in an RPDO,
    IP linear with 0x60C1:1 in an RPDO, else its position loop over profile velocity (0x60FF)."""
    modes = []
    for mode in STREAMING_ORDER:
        needed = _STREAM_NEEDS[mode]
        if needed is None:
            if (obj.for_axis(obj.TARGET_VELOCITY, slot), 0) in exists:
                modes.append(int(mode))
        elif in_rpdo((obj.for_axis(needed[0], slot), needed[1])):
            modes.append(int(mode))
    return tuple(modes)
