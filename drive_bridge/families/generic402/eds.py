"""What the generic family reads in a drive's EDS to fit its default process data: which
objects exist and may be mapped, which PDOs exist, how many entries each takes, which
mappings are fixed, and what the drive maps by default."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from canopen import ObjectDictionary
from canopen.objectdictionary import ODArray, ODRecord, ODVariable

from drive_bridge.cia301.cob import predefined_cob_id

Kind = Literal['rpdo', 'tpdo']
ObjectKey = tuple[int, int]
COMM_BASE = {'rpdo': 0x1400, 'tpdo': 0x1800}
MAP_BASE = {'rpdo': 0x1600, 'tpdo': 0x1A00}
MAX_PDO_BITS = 64
MAX_PDOS = 512
COB_INVALID = 0x80000000


def variable(od: ObjectDictionary, key: ObjectKey) -> ODVariable | None:
    entry = od.get(key[0])
    if isinstance(entry, ODVariable):
        return entry if key[1] == 0 else None
    if isinstance(entry, (ODRecord, ODArray)):
        return entry.subindices.get(key[1])
    return None


def bits_of(var: ODVariable) -> int | None:
    """Bits the variable takes in a PDO (None: no fixed size)."""
    try:
        return len(var.encode_raw(0.0 if var.data_type in (0x08, 0x11) else 0)) * 8
    except Exception:  # strings, domains: no fixed size
        return None


def why_not_mappable(od: ObjectDictionary, key: ObjectKey, kind: Kind) -> str:
    """'' when ``key`` can go into a PDO of ``kind``, else the reason (for the start-up line)."""
    var = variable(od, key)
    if var is None:
        return 'absent'
    if not var.pdo_mappable:
        return 'not PDO-mappable'
    access = var.access_type
    if kind == 'rpdo' and 'w' not in access:
        return f'read-only ({access})'
    if kind == 'tpdo' and 'r' not in access and access != 'const':
        return f'write-only ({access})'
    return '' if bits_of(var) else 'no fixed size'


@dataclass(frozen=True)
class PdoSlot:
    """One PDO the EDS defines: its number, COB-ID, how many entries it takes and, when its
    mapping is read-only, what it holds."""

    kind: Kind
    number: int
    cob_id: int
    room: int
    fixed: tuple[ObjectKey, ...] | None
    default: tuple[ObjectKey, ...]  # the drive's own default mapping
    default_valid: bool  # its COB-ID default has bit 31 clear


def _int(var: ODVariable | None) -> int | None:
    value = None if var is None else (var.value if var.value is not None else var.default)
    return value if isinstance(value, int) else None


def _entries(mapping: ODRecord | ODArray) -> tuple[ObjectKey, ...]:
    count = _int(mapping.subindices.get(0)) or 0
    values = [_int(mapping.subindices.get(s)) for s in range(1, count + 1)]
    return tuple((v >> 16, (v >> 8) & 0xFF) for v in values if v)


def _cob_id(kind: Kind, number: int, node_id: int, comm: ODRecord | ODArray) -> int | None:
    if number <= 4:
        return predefined_cob_id(kind, number, node_id)
    value = _int(comm.subindices.get(1))
    cob = (value or 0) & 0x7FF
    return cob if 0x181 <= cob <= 0x57F else None


def pdo_slots(od: ObjectDictionary, kind: Kind, node_id: int) -> list[PdoSlot]:
    """The PDOs of ``kind`` the EDS defines, in number order."""
    slots = []
    used = {predefined_cob_id(kind, n, node_id) for n in range(1, 5)}  # a PDO > 4 must not reuse them
    for number in range(1, MAX_PDOS + 1):
        comm, mapping = od.get(COMM_BASE[kind] + number - 1), od.get(MAP_BASE[kind] + number - 1)
        if not isinstance(comm, (ODRecord, ODArray)) or not isinstance(mapping, (ODRecord, ODArray)):
            continue
        cob = _cob_id(kind, number, node_id, comm)
        if cob is None or (number > 4 and cob in used):
            continue
        used.add(cob)
        present = len([s for s in mapping.subindices if s >= 1])
        count = mapping.subindices.get(0)
        limit = count.max if count is not None and isinstance(count.max, int) else present
        first = mapping.subindices.get(1)
        fixed = _entries(mapping) if first is not None and 'w' not in first.access_type else None
        cob_default = _int(comm.subindices.get(1)) or 0
        slots.append(PdoSlot(kind, number, cob, min(present, limit), fixed, _entries(mapping),
                             not cob_default & COB_INVALID))
    return slots
