"""The AKD's expedited SDO downloads of another size than the object's [10.15, 12]: more bytes
than the object are truncated; fewer are zero- or sign-extended, unless a byte beyond the
indicated size is not zero, in which case the object's own length is read from the frame (the
manual's ``2B 8F 60 01 00 00 10 00`` then sets 0x608F:1 to 2^20, the value it says it writes)."""
from __future__ import annotations

from canopen.objectdictionary import datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.store import ObjectStore


def fit_expedited(store: ObjectStore, index: int, subindex: int, data: bytes, request: bytes) -> bytes:
    """The data of an expedited download of (index, subindex), fitted to the object's size."""
    try:
        var = store.find(index, subindex)
    except SdoAbortedError:
        return data  # the normal path answers with the right abort
    if var.data_type not in dt.INTEGER_TYPES:
        return data
    size, given = len(var) // 8, len(data)
    if given == size:
        return data
    if given > size:
        return data[:size]  # the unused bytes are ignored
    if size <= 4 and any(request[4 + given:4 + size]):
        return request[4:4 + size]  # the object's own length (the manual's 0x608F:1 example)
    signed = var.data_type in dt.SIGNED_TYPES
    return int.from_bytes(data, 'little', signed=signed).to_bytes(size, 'little', signed=signed)
