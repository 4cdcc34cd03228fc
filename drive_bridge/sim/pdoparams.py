"""CiA 301 rules for writes of a simulated slave's PDO parameters (0x1400-0x1BFF): the
communication parameter (COB-ID, transmission type, inhibit time, SYNC start value) and the
mapping, each refused write with the abort the device answers.

Abort codes for parameter writes (CiA 301 §7.5.2.35-38 leave some choices open):

- mapping (sub0 or an entry) written while the PDO is valid, or an entry written
  while sub0 != 0: 0x08000022 (data cannot be transferred because of the device
  state) -- the state the master must change first;
- mapped object missing: 0x06020000; not PDO-mappable, or not readable (TPDO) /
  writable (RPDO), or a dummy entry: 0x06040041; entry length differs from the
  object's size: 0x06040043; more than 64 bits at sub0 = n: 0x06040042; sub0 larger
  than the number of entries: 0x06090031;
- COB-ID bits 0-29 changed while valid, 29-bit id, restricted CAN-ID, reserved or
  RTR-only transmission type (241..253), inhibit time or SYNC start value changed
  while valid, SYNC start value > 240: 0x06090030.
"""
from __future__ import annotations

from collections.abc import Callable

from canopen.objectdictionary import ODVariable
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.pdocodec import COB_INVALID, DUMMY_INDICES, Pdo, packable
from drive_bridge.sim.store import ObjectStore, key

PDO_PARAMETERS = (0x1400, 0x1BFF)
COB_NO_RTR = 1 << 30
COB_EXTENDED = 1 << 29
MAX_BITS = 64

ABORT_UNSUPPORTED_ACCESS_STATE = 0x08000022
ABORT_NOT_IN_OD = 0x06020000
ABORT_NOT_MAPPABLE = 0x06040041
ABORT_PDO_TOO_LONG = 0x06040042
ABORT_INCOMPATIBLE = 0x06040043
ABORT_INVALID_VALUE = 0x06090030
ABORT_VALUE_TOO_HIGH = 0x06090031


def restricted_can_id(can_id: int) -> bool:
    """CAN-IDs CiA 301 (table 62) reserves for other services."""
    return (can_id == 0 or 0x001 <= can_id <= 0x07F or 0x101 <= can_id <= 0x180
            or 0x581 <= can_id <= 0x5FF or 0x601 <= can_id <= 0x67F or 0x6E0 <= can_id <= 0x6FF
            or 0x701 <= can_id <= 0x77F or 0x780 <= can_id <= 0x7FF)


def _abort(code: int) -> SdoAbortedError:
    return SdoAbortedError(code)


def check_mapping_entry(store: ObjectStore, pdo: Pdo, entry: int) -> ODVariable:
    """The mapped variable of mapping ``entry`` for ``pdo``, or the CiA 301 abort."""
    index, sub, bits = entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF
    if index in DUMMY_INDICES:
        raise _abort(ABORT_NOT_MAPPABLE)  # the EDS declares no dummy usage
    var = store.variables.get(key(index, sub))
    if var is None:
        raise _abort(ABORT_NOT_IN_OD)
    usable = var.readable if pdo.transmit else var.writable
    if not var.pdo_mappable or not usable or not packable(var):
        raise _abort(ABORT_NOT_MAPPABLE)
    if bits != len(var):
        raise _abort(ABORT_INCOMPATIBLE)
    return var


def check_parameter_write(store: ObjectStore, pdo: Pdo, index: int, subindex: int, value: int, *,
                          locked: bool, check_entry: Callable[[Pdo, int], ODVariable]) -> None:
    """Raise the CiA 301 abort for a write of ``pdo``'s parameter ``index``:``subindex`` the device
    must refuse; ``locked``: its COB-ID and mapping are locked (the PDO is valid)."""
    values = store.values
    if index == pdo.comm:
        cob = values[key(pdo.comm, 1)]
        if subindex == 1:
            if value & COB_EXTENDED:
                raise _abort(ABORT_INVALID_VALUE)
            new_valid = not value & COB_INVALID
            if locked and new_valid and (value & 0x1FFFFFFF) != (cob & 0x1FFFFFFF):
                raise _abort(ABORT_INVALID_VALUE)
            if new_valid and restricted_can_id(value & 0x7FF):
                raise _abort(ABORT_INVALID_VALUE)
        elif subindex == 2:
            if 241 <= value <= 253:
                raise _abort(ABORT_INVALID_VALUE)
        elif subindex == 3 and pdo.transmit:
            if locked and value != values[key(pdo.comm, 3)]:
                raise _abort(ABORT_INVALID_VALUE)
        elif subindex == 6 and pdo.transmit and (value > 240 or (locked and value != values[key(pdo.comm, 6)])):
            raise _abort(ABORT_INVALID_VALUE)
        return
    # mapping parameter
    if locked:
        raise _abort(ABORT_UNSUPPORTED_ACCESS_STATE)
    if subindex == 0:
        entries = sorted(s for k in store.keys_between(index, index) if (s := k & 0xFF) > 0)
        if value > len(entries):
            raise _abort(ABORT_VALUE_TOO_HIGH)
        bits = 0
        for sub in range(1, value + 1):
            entry = values[key(index, sub)]
            if entry == 0:
                raise _abort(ABORT_NOT_IN_OD)
            check_entry(pdo, entry)
            bits += entry & 0xFF
        if bits > MAX_BITS:
            raise _abort(ABORT_PDO_TOO_LONG)
        return
    if values[key(index, 0)] != 0:
        raise _abort(ABORT_UNSUPPORTED_ACCESS_STATE)
    if value != 0:
        check_entry(pdo, value)
