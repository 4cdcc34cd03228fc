"""Object names and data types: the node's EDS when given, else CiA 301/402 (the shipped
generic CiA 402 EDS holds the standard objects), else the hex index. An object of axis slot n
(0x6000 + 0x800 n) is named by slot 0's only when that is a CiA 402 object: 0x7000 is no
"axis 3" of 0x6000 (a CiA 401 object), it is the device's own. The standard objects come from
``standard_objects`` (canopen's reading of the generic EDS, generated): canopen is imported
only for an EDS the user gives, not to name the objects of a bare log.
"""
from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING

from drive_bridge.bag.diagnose.standard_objects import ARRAYS, RECORDS, VARIABLES

if TYPE_CHECKING:
    from canopen.objectdictionary import ObjectDictionary

_SIGNED = {0x02, 0x03, 0x04, 0x10, 0x15}  # INTEGER8/16/32/24/64
_STANDARD_EXTRA = {0x1001: 'Error register', 0x1002: 'Manufacturer status register',
                   0x1010: 'Store parameters', 0x1011: 'Restore default parameters',
                   0x1012: 'COB-ID time stamp', 0x1029: 'Error behaviour', 0x1F51: 'Program control',
                   0x6000: 'Read input 8-bit', 0x6200: 'Write output 8-bit', 0x6401: 'Read analogue input 16-bit',
                   0x6411: 'Write analogue output 16-bit', 0x6502: 'Supported drive modes'}


Entry = tuple[str, bool | None]  # (name, signed; None: no such variable)


def _from_od(od: ObjectDictionary, index: int, subindex: int) -> Entry | None:
    """The entry of a user's EDS (canopen's object dictionary), None when it lacks the object."""
    from canopen.objectdictionary import ODVariable

    if index not in od:
        return None
    obj = od[index]
    if isinstance(obj, ODVariable):
        return obj.name, obj.data_type in _SIGNED
    try:
        sub = obj[subindex]
    except KeyError:
        return obj.name, None
    return f'{obj.name}: {sub.name}' if sub.name != obj.name else obj.name, sub.data_type in _SIGNED


def _standard(index: int, subindex: int) -> Entry | None:
    """The same from the generic EDS' table (an array's undefined subindex as canopen names it)."""
    variable = VARIABLES.get(index)
    if variable is not None:
        return variable
    container = RECORDS.get(index) or ARRAYS.get(index)
    if container is None:
        return None
    name, subs = container
    sub = subs.get(subindex)
    if sub is None and index in ARRAYS and 0 < subindex < 256 and 1 in subs:
        sub = f'{subs[1][0]}_{subindex:x}', subs[1][1]
    if sub is None:
        return name, None
    return f'{name}: {sub[0]}' if sub[0] != name else name, sub[1]


def _variable(od: ObjectDictionary | None, index: int, subindex: int) -> Entry:
    entry = _from_od(od, index, subindex) if od is not None else None
    if entry is None:
        entry = _standard(index, subindex)
    return entry if entry is not None else ('', None)


def _standard_base(index: int) -> int:
    """CiA 402 axis objects of slot n sit at +0x800 * n: name them by slot 0's object."""
    return 0x6000 + ((index - 0x6000) & 0x7FF) if 0x6000 <= index < 0xA000 else index


@lru_cache(maxsize=4096)
def _name_cached(od_id: int, index: int, subindex: int) -> str:
    od = _ODS.get(od_id)
    name, _var = _variable(od, index, subindex)
    if not name:
        base = _standard_base(index)
        if base == index:
            name = _STANDARD_EXTRA.get(index, '')
        elif 0x6040 <= base < 0x6800:  # CiA 402 objects only (0x6000-0x603F: CiA 401 I/O and others)
            name, _var = _variable(None, base, subindex)
            name = name and f'{name} (axis {(index - 0x6000) // 0x800 + 1})'
    return name


_ODS: dict[int, ObjectDictionary] = {}


def object_name(od: ObjectDictionary | None, index: int, subindex: int) -> str:
    """'Statusword', 'Identity object: Vendor-ID', ... ('' when nobody knows the object)."""
    if od is not None:
        _ODS[id(od)] = od
    return _name_cached(id(od) if od is not None else 0, index, subindex)


def object_label(od: ObjectDictionary | None, index: int, subindex: int) -> str:
    name = object_name(od, index, subindex)
    return f'0x{index:04X}:{subindex}' + (f' {name}' if name else '')


def is_signed(od: ObjectDictionary | None, index: int, subindex: int) -> bool:
    if od is not None:
        _ODS[id(od)] = od
    return _signed_cached(id(od) if od is not None else 0, index, subindex)


@lru_cache(maxsize=4096)
def _signed_cached(od_id: int, index: int, subindex: int) -> bool:
    od = _ODS.get(od_id)
    _name, signed = _variable(od, index, subindex)
    if signed is None and 0x6040 <= _standard_base(index) < 0x6800:
        _name, signed = _variable(None, _standard_base(index), subindex)
    return bool(signed)
