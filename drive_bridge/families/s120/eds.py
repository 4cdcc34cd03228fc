"""The S120's EDS adapted to the configured axis slots (``prepare_object_dictionary``).

Siemens ships two kinds of EDS (neither is shipped here: the config names one with ``dcf``):

- the **modular** multi-DO EDS of firmware V4.8 (``SINAMICS_S120.eds``, CiA 306 modules
  ``[M1..M6]``): canopen reads only its node objects (0x1000..0x1201), the per-DO objects live
  in module sections it skips. The objects of each configured slot are added here, as the
  modules describe them: the PDO parameters 0x1400/0x1600/0x1800/0x1A00 + k (k = 0..7) moved
  by 0x40 per slot, the CiA 402 objects of Tab. 2-6 moved by 0x800 per slot, with the types,
  access and PDO mappability the modules give (:data:`PROFILE_TEMPLATE`);
- the older **flat** EDS (``sinamics_s120.eds``): the objects of the first drive object. It
  is taken as it is; a further configured slot gets a copy of slot 0's objects moved to its
  offsets (the manual: every further DO has the same objects at +0x40 / +0x80 / +0x800).

Defaults of the added objects follow the V4.8 modules: slot 0's PDOs 1..4 carry the predefined
connection set of the node id (0x200/0x300/0x400/0x500 + id, 0x180/.. + id with "no RTR"),
every other PDO is invalid (0x800006DF / 0xC00006DF); mappings as Tab. 2-3 / 2-4 with the
entries moved by 0x800 per slot. A file without any CiA 402 drive object and without the modular
multi-axis device type (0x1000 = 0xFFFF0192) is refused: it is not the S120's node EDS (e.g. a
DO manufacturer fragment such as ``SINAMICS_SERVO.eds``).
"""
from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass

from canopen import ObjectDictionary
from canopen.objectdictionary import ODArray, ODRecord, ODVariable, datatypes as dt

from drive_bridge.cia402 import objects as cia
from drive_bridge.families.s120 import objects as s

MULTI_DEVICE = 0xFFFF  # device type 0x1000, upper word: several logical devices (the modular EDS)
DRIVE_PROFILE = 0x0192  # CiA 402
RPDO_INVALID = 0x800006DF
TPDO_INVALID = 0xC00006DF
NO_RTR = 0x40000000
TRANSMISSION_ASYNC = 0xFE  # every PDO's default (§2.7.2)

# Tab. 2-3 / 2-4: default mappings of the first drive object (entries as index << 16 | sub << 8 | bits)
RPDO_DEFAULTS: tuple[tuple[int, ...], ...] = (
    (0x60400010,), (0x60400010, 0x60FF0020), (0x60400010, 0x60710010), (0x60400010, 0x60FF0020, 0x60710010))
TPDO_DEFAULTS: tuple[tuple[int, ...], ...] = (
    (0x60410010,), (0x60410010, 0x606C0020), (0x60410010, 0x60770010), (0x60410010, 0x60630020))


@dataclass(frozen=True)
class ProfileObject:
    """One CiA 402 object of a drive object, as the V4.8 modules describe it (Tab. 2-6)."""

    index: int
    name: str
    data_type: int
    access: str  # 'rw', 'ro', 'rww' (writable, mappable), 'const'
    mappable: bool
    default: int | str | None = None
    subs: tuple[tuple[str, int, str, int | None], ...] = ()  # records/arrays: (name, type, access, default)


PROFILE_TEMPLATE: tuple[ProfileObject, ...] = (
    ProfileObject(0x6007, 'Abort connection option code', dt.INTEGER16, 'rw', False, 3),
    ProfileObject(0x6040, 'Controlword', dt.UNSIGNED16, 'rww', True, 0),
    ProfileObject(0x6041, 'Statusword', dt.UNSIGNED16, 'ro', True, 0),
    ProfileObject(0x6042, 'vl target velocity', dt.INTEGER16, 'rww', True, 0),
    ProfileObject(0x6043, 'vl velocity demand', dt.INTEGER16, 'ro', True, 0),
    ProfileObject(0x6044, 'vl velocity actual value', dt.INTEGER16, 'ro', True, 0),
    ProfileObject(0x6046, 'vl velocity min max amount', 0, '', False, None, (
        ('number of entries', dt.UNSIGNED8, 'ro', 2), ('vl velocity min amount', dt.UNSIGNED32, 'rw', None),
        ('vl velocity max amount', dt.UNSIGNED32, 'rw', None))),
    ProfileObject(0x6048, 'vl velocity acceleration', 0, '', False, None, (
        ('number of entries', dt.UNSIGNED8, 'ro', 2), ('delta speed', dt.UNSIGNED32, 'rw', None),
        ('delta time', dt.UNSIGNED16, 'rw', None))),
    ProfileObject(0x605D, 'Halt option code', dt.INTEGER16, 'rw', False, None),
    ProfileObject(0x6060, 'Modes of operation', dt.INTEGER8, 'rww', True, None),
    ProfileObject(0x6061, 'Modes of operation display', dt.INTEGER8, 'ro', True, None),
    ProfileObject(0x6063, 'Position actual value', dt.INTEGER32, 'ro', True, 0),
    ProfileObject(0x6069, 'Velocity sensor actual value', dt.INTEGER32, 'ro', True, None),
    ProfileObject(0x606B, 'Velocity demand value', dt.INTEGER32, 'ro', True, None),
    ProfileObject(0x606C, 'Velocity actual value', dt.INTEGER32, 'ro', True, None),
    ProfileObject(0x6071, 'Target torque', dt.INTEGER16, 'rww', True, 0),
    ProfileObject(0x6072, 'Max torque', dt.UNSIGNED16, 'rw', False, 0),
    ProfileObject(0x6074, 'Torque demand value', dt.INTEGER16, 'ro', True, 0),
    ProfileObject(0x6077, 'Torque actual value', dt.INTEGER16, 'ro', True, 0),
    ProfileObject(0x6083, 'Profile acceleration', dt.UNSIGNED32, 'rw', False, None),
    ProfileObject(0x6084, 'Profile deceleration', dt.UNSIGNED32, 'rw', False, None),
    ProfileObject(0x6085, 'Quick stop deceleration', dt.UNSIGNED32, 'rw', False, None),
    ProfileObject(0x6086, 'Motion profile type', dt.INTEGER16, 'rw', False, 0),
    ProfileObject(0x6094, 'Velocity encoder factor', 0, '', False, None, (
        ('number of entries', dt.UNSIGNED8, 'ro', 2), ('numerator', dt.UNSIGNED32, 'rw', 1),
        ('divisor', dt.UNSIGNED32, 'rw', 1))),
    ProfileObject(0x60FF, 'Target velocity', dt.INTEGER32, 'rww', True, 0),
    ProfileObject(0x6502, 'Supported drive modes', dt.UNSIGNED32, 'ro', False, None),
    ProfileObject(0x6504, 'Drive manufacturer', dt.VISIBLE_STRING, 'const', False, 'SIEMENS'),
    ProfileObject(0x67FF, 'Single device type', dt.UNSIGNED32, 'ro', False, 0x20192),
)


def _variable(name: str, index: int, subindex: int, data_type: int, access: str, default: int | str | None,
              mappable: bool = False, low: int | None = None, high: int | None = None) -> ODVariable:
    var = ODVariable(name, index, subindex)
    var.data_type = data_type
    var.access_type = access
    var.default = default  # type: ignore[assignment]  # canopen types it int | None; strings are defaults too
    var.pdo_mappable = mappable
    var.min, var.max = low, high
    return var


def _record(name: str, index: int, members: Sequence[ODVariable]) -> ODRecord:
    record = ODRecord(name, index)
    for var in members:
        var.index = index
        record.add_member(var)
    return record


def _node_id(od: ObjectDictionary) -> int | None:
    """The node id the EDS was read for ($NODEID in the default SDO server 0x1200:1 = 0x600 + id)."""
    server = od.get(0x1200)
    if not isinstance(server, (ODRecord, ODArray)) or 1 not in server.subindices:
        return None
    default = server.subindices[1].default
    return default - 0x600 if isinstance(default, int) and 0x601 <= default <= 0x67F else None


def _rpdo_comm(slot: int, k: int, node_id: int | None) -> ODRecord:
    index = s.RPDO_COMM + s.PDO_OFFSET * slot + k
    cob = 0x200 + 0x100 * k + node_id if slot == 0 and k < 4 and node_id else RPDO_INVALID
    return _record(f'RPDO {s.pdo_number(slot, k)} communication parameter', index, (
        _variable('Number of entries', index, 0, dt.UNSIGNED8, 'ro', 2),
        _variable('COB-ID', index, 1, dt.UNSIGNED32, 'rw', cob, low=1, high=RPDO_INVALID),
        _variable('Transmission type', index, 2, dt.UNSIGNED8, 'rw', TRANSMISSION_ASYNC, low=0, high=0xFF)))


def _tpdo_comm(slot: int, k: int, node_id: int | None) -> ODRecord:
    index = s.TPDO_COMM + s.PDO_OFFSET * slot + k
    cob = NO_RTR | 0x180 + 0x100 * k + node_id if slot == 0 and k < 4 and node_id else TPDO_INVALID
    return _record(f'TPDO {s.pdo_number(slot, k)} communication parameter', index, (
        _variable('Number of entries', index, 0, dt.UNSIGNED8, 'ro', 5),
        _variable('COB-ID', index, 1, dt.UNSIGNED32, 'rw', cob, low=1, high=TPDO_INVALID),
        _variable('Transmission type', index, 2, dt.UNSIGNED8, 'rw', TRANSMISSION_ASYNC, low=0, high=0xFF),
        _variable('Inhibit time', index, 3, dt.UNSIGNED16, 'rw', 0),
        _variable('Compatibility entry', index, 4, dt.UNSIGNED8, 'rw', 0),
        _variable('Event timer', index, 5, dt.UNSIGNED16, 'rw', 0)))


def shifted_entry(entry: int, slot: int) -> int:
    """A mapping entry of slot 0 for ``slot`` (a CiA 402 object moved by 0x800 per slot)."""
    index = entry >> 16
    return (cia.for_axis(index, slot) << 16 | entry & 0xFFFF) if entry else 0


def _mapping(kind: str, slot: int, k: int) -> ODRecord:
    base = s.RPDO_MAP if kind == 'RPDO' else s.TPDO_MAP
    defaults = RPDO_DEFAULTS if kind == 'RPDO' else TPDO_DEFAULTS
    index = base + s.PDO_OFFSET * slot + k
    entries = [shifted_entry(e, slot) for e in (defaults[k] if k < len(defaults) else ())]
    entries += [0] * (s.MAX_PDO_ENTRIES - len(entries))
    return _record(f'{kind} {s.pdo_number(slot, k)} mapping parameter', index, (
        _variable('Number of mapped objects', index, 0, dt.UNSIGNED8, 'rw', sum(1 for e in entries if e),
                  low=0, high=s.MAX_PDO_ENTRIES),
        *(_variable('PDO mapping entry', index, n + 1, dt.UNSIGNED32, 'rw', e) for n, e in enumerate(entries))))


def _profile_object(template: ProfileObject, slot: int) -> ODVariable | ODRecord | ODArray:
    index = cia.for_axis(template.index, slot)
    name = template.name if slot == 0 else f'{template.name} (slot {slot})'
    if not template.subs:
        return _variable(name, index, 0, template.data_type, template.access, template.default, template.mappable)
    record = ODRecord(name, index)
    for sub, (sub_name, data_type, access, default) in enumerate(template.subs):
        record.add_member(_variable(sub_name, index, sub, data_type, access, default))
    return record


def slot_objects(slot: int, node_id: int | None) -> list[ODVariable | ODRecord | ODArray]:
    """Every object of the drive object in ``slot`` as the V4.8 modules describe it."""
    found: list[ODVariable | ODRecord | ODArray] = []
    for k in range(s.PDOS_PER_SLOT):
        found += [_rpdo_comm(slot, k, node_id), _mapping('RPDO', slot, k),
                  _tpdo_comm(slot, k, node_id), _mapping('TPDO', slot, k)]
    found += [_profile_object(t, slot) for t in PROFILE_TEMPLATE]
    return found


def _copy_variable(var: ODVariable, index: int) -> ODVariable:
    clone = copy.copy(var)  # shallow: ``parent`` is set when it is added
    clone.index = index
    return clone


def _moved(entry: ODVariable | ODRecord | ODArray, slot: int) -> ODVariable | ODRecord | ODArray:
    """A copy of a slot-0 object at ``slot``'s index; PDO defaults as a further DO has them."""
    index = s.shifted_index(entry.index, slot)
    name = f'{entry.name} (slot {slot})'
    if isinstance(entry, ODVariable):
        clone = _copy_variable(entry, index)
        clone.name = name
        return clone
    comm = any(b <= entry.index < b + s.PDOS_PER_SLOT for b in (s.RPDO_COMM, s.TPDO_COMM))
    mapping = any(b <= entry.index < b + s.PDOS_PER_SLOT for b in (s.RPDO_MAP, s.TPDO_MAP))
    record: ODRecord | ODArray = ODRecord(name, index) if isinstance(entry, ODRecord) else ODArray(name, index)
    for sub in sorted(entry.subindices):
        var = _copy_variable(entry.subindices[sub], index)
        if comm and sub == 1:
            var.default = TPDO_INVALID if entry.index >= s.TPDO_COMM else RPDO_INVALID
        elif mapping and sub >= 1 and isinstance(var.default, int):
            var.default = shifted_entry(var.default, slot)
        record.add_member(var)
    return record


def _has_drive_object(od: ObjectDictionary, slot: int) -> bool:
    return cia.for_axis(cia.CONTROLWORD, slot) in od or s.RPDO_COMM + s.PDO_OFFSET * slot in od


def _device_type(od: ObjectDictionary) -> int | None:
    try:
        default = od[0x1000].default  # type: ignore[union-attr]
    except (KeyError, AttributeError):
        return None
    return default if isinstance(default, int) else None


def prepare(od: ObjectDictionary, slots: Sequence[int]) -> list[str]:
    """Add the objects of every configured slot the EDS lacks (see the module docstring);
    returns problems (the EDS is not an S120 node EDS)."""
    wanted = sorted(set(slots) | {0})
    if not _has_drive_object(od, 0):
        device = _device_type(od)
        if device is None or device >> 16 != MULTI_DEVICE or device & 0xFFFF != DRIVE_PROFILE:
            shown = 'missing' if device is None else f'0x{device:08X}'
            return ['it describes no drive object (no 0x6040, no 0x1400) and is not the modular multi-DO EDS '
                    f'(device type 0x1000 {shown}, expected 0xFFFF0192); give the S120 node EDS '
                    '(SINAMICS_S120.eds of the firmware, or the flat sinamics_s120.eds)']
        node_id = _node_id(od)
        for slot in wanted:
            for entry in slot_objects(slot, node_id):
                if entry.index not in od:
                    od.add_object(entry)
        return []
    base = [od[index] for index in sorted(od.indices) if s.per_slot(index)]
    for slot in wanted:
        if slot == 0 or _has_drive_object(od, slot):
            continue
        for entry in base:
            if s.shifted_index(entry.index, slot) not in od:
                od.add_object(_moved(entry, slot))
    return []
