"""PDO maps: lely's ``rpdo``/``tpdo`` syntax or the family default, checked against
the node's object dictionary (existence, mappability, access, 64 bits, fixed maps)
and, bus-wide, for unique and allowed COB-IDs."""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Literal

from canopen import ObjectDictionary
from canopen.objectdictionary import ODArray, ODRecord

from drive_bridge.cia301.cob import predefined_cob_id
from drive_bridge.config import keys
from drive_bridge.config.errors import Issues, Loc
from drive_bridge.config.odcheck import (
    hex_cob,
    hex_index,
    is_readable,
    is_writable,
    lookup,
    pdo_bits,
    ref,
    type_name,
    var_ref,
)
from drive_bridge.config.reader import Section, describe, parse_int_text
from drive_bridge.config.sdo import read_index
from drive_bridge.model import PdoConfig, PdoEntry

Kind = Literal['rpdo', 'tpdo']
MAX_PDO_BITS = 64
COMM_BASE = {'rpdo': 0x1400, 'tpdo': 0x1800}
MAP_BASE = {'rpdo': 0x1600, 'tpdo': 0x1A00}
TRANSMISSION = {  # CiA 301: 241..251 reserved; 252/253 (RTR) exist for TPDOs only
    'rpdo': (frozenset(range(0, 241)) | {254, 255}, '0..240 (synchronous), 254 or 255 (event-driven)'),
    'tpdo': (frozenset(range(0, 241)) | {252, 253, 254, 255},
             '0..240 (synchronous), 252/253 (on RTR), 254 or 255 (event-driven)'),
}
# COB-IDs a PDO must not use (CiA 301 restricted identifiers and the predefined services)
RESERVED: tuple[tuple[int, int, str], ...] = (
    (0x000, 0x000, 'NMT'), (0x001, 0x07F, 'CiA 301 restricted use'), (0x080, 0x080, 'SYNC'),
    (0x081, 0x0FF, 'EMCY'), (0x100, 0x100, 'TIME'), (0x101, 0x180, 'CiA 301 restricted use'),
    (0x581, 0x5FF, 'SDO responses'), (0x601, 0x67F, 'SDO requests'), (0x6E0, 0x6FF, 'CiA 301 restricted use'),
    (0x701, 0x77F, 'heartbeat / node guarding'), (0x780, 0x7FF, 'CiA 301 restricted use (LSS)'),
)


@dataclass(frozen=True)
class EntryDraft:
    loc: Loc
    prefix: str  # what the location cannot say (e.g. which family default)
    index: int
    subindex: int
    bits: int | None = None  # known for family defaults


@dataclass(frozen=True)
class PdoDraft:
    """A PDO with the locations its checks report at."""

    kind: Kind
    config: PdoConfig
    loc: Loc
    cob_loc: Loc
    prefix: str
    label: str
    entries: tuple[EntryDraft, ...] = field(default=())
    from_family: bool = False

    @property
    def name(self) -> str:
        return f'{self.kind[0].upper()}PDO {self.config.number}'


def _pdo_number(key: Any) -> int | None:
    number = key if isinstance(key, int) and not isinstance(key, bool) else (
        int(key) if isinstance(key, str) and key.strip().isdigit() else None)
    return number if number is not None and 1 <= number <= 512 else None


def _cob_id(sec: Section, kind: Kind, number: int, node_id: int) -> int | None:
    raw = sec.get('cob_id', 'auto')
    loc = sec.loc('cob_id') if 'cob_id' in sec else sec.where
    if isinstance(raw, str) and raw.strip().lower() == 'auto':
        if 1 <= number <= 4:
            return predefined_cob_id(kind, number, node_id)
        sec.issues.error(loc, f"cob_id 'auto' only works for PDOs 1..4 (CiA 301's predefined connection set); "
                              f'give {kind.upper()} {number} an explicit cob_id')
        return None
    value = parse_int_text(raw, allow_str=True)
    if value is None or not 0x001 <= value <= 0x7FF:
        hint = ' (use enabled: false instead of bit 31)' if value is not None and value & 0x80000000 else ''
        sec.issues.error(loc, f"expected 'auto' or an 11-bit COB-ID 0x001..0x7FF, got {describe(raw)}{hint}")
        return None
    return value


def _transmission(sec: Section, kind: Kind, default: int) -> int:
    if 'transmission' in sec and 'transmission_type' in sec:
        sec.issues.error(sec.loc('transmission_type'),
                         f'give either transmission or transmission_type, not both ({sec.loc("transmission").path})')
    key = 'transmission_type' if 'transmission_type' in sec else 'transmission'
    if key not in sec:
        return default
    allowed, text = TRANSMISSION[kind]
    value = sec.get(key)
    if isinstance(value, bool) or not isinstance(value, int) or value not in allowed:
        sec.issues.error(sec.loc(key), f'expected a transmission type {text} for a{"n R" if kind == "rpdo" else " T"}'
                                       f'PDO, got {describe(value)}')
        return default
    return value


def _entries(sec: Section) -> tuple[EntryDraft, ...]:
    items = sec.get_list('mapping', 'a list of {index, sub_index}')
    drafts = []
    for loc, value in items or []:
        item = Section.of(sec.issues, value, loc, 'a mapping {index, sub_index}')
        if item is None:
            continue
        item.check_keys(keys.MAPPING_ENTRY)
        index, subindex = read_index(item)
        if index is not None and subindex is not None:
            drafts.append(EntryDraft(loc, '', index, subindex))
    return tuple(drafts)


def parse_pdo_table(issues: Issues, value: Any, loc: Loc, kind: Kind, node_id: int, node_name: str,
                    transmission_default: int) -> list[PdoDraft]:
    """The PDOs of an explicit ``rpdo``/``tpdo`` mapping (PDO number -> section)."""
    if value is None:
        return []
    if not isinstance(value, Mapping):
        issues.error(loc, f'expected a mapping of PDO number (1..512) -> PDO section, got {describe(value)}')
        return []
    drafts: dict[int, PdoDraft] = {}
    allowed = keys.RPDO if kind == 'rpdo' else keys.TPDO
    other = 'TPDO' if kind == 'rpdo' else 'RPDO'
    hints = {k: f'{k} applies to {other}s only' for k in (keys.TPDO if kind == 'rpdo' else keys.RPDO)
             if k not in allowed}
    hints.update({k: f'{k} applies to RPDOs only' for k in keys.RPDO_IGNORED if kind == 'tpdo'})
    for key, item in value.items():
        number = _pdo_number(key)
        where = loc.key(key)
        if number is None:
            issues.error(where, f'expected a PDO number 1..512 as key, got {describe(key)}')
            continue
        if number in drafts:
            issues.error(where, f'{kind.upper()} {number} is given twice (also {drafts[number].loc.path})')
            continue
        sec = Section.of(issues, item, where, 'a PDO section (a mapping)')
        if sec is None:
            continue
        sec.check_keys(allowed, keys.RPDO_IGNORED if kind == 'rpdo' else None, hints)
        tpdo = kind == 'tpdo'
        config = PdoConfig(
            number=number, cob_id=_cob_id(sec, kind, number, node_id) or 0,
            enabled=sec.get_bool('enabled', True),
            transmission=_transmission(sec, kind, transmission_default),
            inhibit_time=(sec.get_int('inhibit_time', 0, lo=0, hi=0xFFFF) or 0) if tpdo else 0,
            event_timer=sec.get_int('event_timer', 0, lo=0, hi=0xFFFF) or 0,
            sync_start=(sec.get_int('sync_start', 0, lo=0, hi=240) or 0) if tpdo else 0)
        entries = _entries(sec)
        if config.enabled and sec.require('mapping', 'a list of {index, sub_index}') \
                and sec.get('mapping') in ([], None):
            issues.error(sec.loc('mapping'), 'an enabled PDO needs at least one mapped object '
                                             '(or set enabled: false)')
        cob_loc = sec.loc('cob_id') if 'cob_id' in sec else where
        label = f"{where.path} ({kind.upper()} {number} of node '{node_name}')"
        drafts[number] = PdoDraft(kind, config, where, cob_loc, '', label, entries)
    return [drafts[n] for n in sorted(drafts)]


def family_drafts(configs: Iterable[PdoConfig], kind: Kind, node_loc: Loc, family: str,
                  node_name: str) -> list[PdoDraft]:
    """Drafts of a family's default PDOs; they report at the node with a prefix saying
    which default entry is meant (the file has no line for them)."""
    drafts = []
    for config in configs:
        name = f"family '{family}' default {kind.upper()} {config.number}"
        entries = tuple(EntryDraft(node_loc, f'{name} mapping[{i}]: ', e.index, e.subindex, e.bits)
                        for i, e in enumerate(config.mapping))
        drafts.append(PdoDraft(kind, config, node_loc, node_loc, f'{name}: ',
                               f"the {name} of node '{node_name}'", entries, from_family=True))
    return drafts


def _fixed_mapping(mapping: ODRecord | ODArray) -> list[tuple[int, int, int]] | None:
    """The mapping a read-only mapping parameter holds (from the EDS defaults); None if writable."""
    first = mapping.subindices.get(1)
    if first is None or is_writable(first):
        return None
    count_var = mapping.subindices.get(0)
    count = count_var.default if count_var is not None and isinstance(count_var.default, int) else 0
    values = [mapping.subindices[s].default for s in range(1, count + 1) if s in mapping.subindices]
    return [(v >> 16, (v >> 8) & 0xFF, v & 0xFF) for v in values if isinstance(v, int)]


def _check_entry(issues: Issues, od: ObjectDictionary, eds_name: str, kind: Kind,
                 entry: EntryDraft) -> PdoEntry | None:
    found = lookup(od, eds_name, entry.index, entry.subindex)
    if found.var is None:
        issues.error(entry.loc, entry.prefix + found.problem)
        return None
    var = found.var
    problems = []
    if not var.pdo_mappable:
        problems.append(f'{var_ref(var)} is not PDO-mappable in {eds_name}')
    elif kind == 'rpdo' and not is_writable(var):
        problems.append(f'{var_ref(var)} is read-only (access {var.access_type}) in {eds_name}; '
                        'an RPDO can only map writable objects')
    elif kind == 'tpdo' and not is_readable(var):
        problems.append(f'{var_ref(var)} is write-only (access {var.access_type}) in {eds_name}; '
                        'a TPDO can only map readable objects')
    bits = pdo_bits(var)
    if bits is None:
        problems.append(f'{var_ref(var)} has data type {type_name(var.data_type)}, which has no fixed '
                        'size in a PDO')
    elif entry.bits is not None and entry.bits != bits:
        problems.append(f'maps {ref(entry.index, entry.subindex)} with {entry.bits} bits, but {eds_name} '
                        f'gives it {type_name(var.data_type)} ({bits} bits)')
    for problem in problems:
        issues.error(entry.loc, entry.prefix + problem)
    return None if problems or bits is None else PdoEntry(entry.index, entry.subindex, bits)


def resolve_pdo(issues: Issues, od: ObjectDictionary, eds_name: str, draft: PdoDraft) -> PdoDraft:
    """The draft with its mapping checked against ``od`` and bit sizes filled in."""
    number, kind = draft.config.number, draft.kind
    comm, mapping_index = COMM_BASE[kind] + number - 1, MAP_BASE[kind] + number - 1
    have = sum(1 for i in range(COMM_BASE[kind], COMM_BASE[kind] + 512) if i in od)
    for index, what in ((comm, 'communication'), (mapping_index, 'mapping')):
        if index not in od:
            issues.error(draft.loc, f'{draft.prefix}{draft.name} is not available in {eds_name}: it has no '
                                    f'{hex_index(index)} {what} parameter ({have} {kind.upper()}s defined)')
            return draft
    entries = [_check_entry(issues, od, eds_name, kind, e) for e in draft.entries]
    mapping = od[mapping_index]
    if isinstance(mapping, (ODRecord, ODArray)):
        room = len([s for s in mapping.subindices if s >= 1])
        fixed = _fixed_mapping(mapping)
        wanted = [(e.index, e.subindex, e.bits or 0) for e in entries if e is not None]
        if len(draft.entries) > room:
            issues.error(draft.loc, f'{draft.prefix}{len(draft.entries)} objects mapped, but '
                                    f'{hex_index(mapping_index)} in {eds_name} has room for {room}')
        elif fixed is not None and None not in entries and wanted != fixed:
            fixed_text = ', '.join(f'{hex_index(i)}:{s:02X} ({b} bits)' for i, s, b in fixed) or 'nothing'
            issues.error(draft.loc, f'{draft.prefix}the mapping of {draft.name} is fixed in {eds_name} '
                                    f'({hex_index(mapping_index)} is read-only) and holds {fixed_text}; '
                                    'map exactly that or use another PDO')
    resolved = tuple(e for e in entries if e is not None)
    bits = sum(e.bits for e in resolved)
    if bits > MAX_PDO_BITS:
        sizes = ', '.join(f'{hex_index(e.index)}:{e.subindex:02X} {e.bits}' for e in resolved)
        where = draft.loc.key('mapping') if not draft.prefix else draft.loc
        issues.error(where, f'{draft.prefix}{bits} bits mapped ({sizes}); a PDO carries at most {MAX_PDO_BITS}')
    return replace(draft, config=replace(draft.config, mapping=resolved))


def check_cob_ids(issues: Issues, drafts: Iterable[PdoDraft]) -> None:
    """Every enabled PDO on the bus has its own COB-ID, outside the reserved ones."""
    used: dict[int, PdoDraft] = {}
    for draft in drafts:
        cob = draft.config.cob_id
        if not draft.config.enabled or cob == 0:
            continue
        reserved = next(((lo, hi, what) for lo, hi, what in RESERVED if lo <= cob <= hi), None)
        if reserved is not None:
            lo, hi, what = reserved
            span = hex_cob(lo) if lo == hi else f'{hex_cob(lo)}..{hex_cob(hi)}'
            issues.error(draft.cob_loc, f'{draft.prefix}COB-ID {hex_cob(cob)} is reserved for {what} ({span})')
        elif cob in used:
            issues.error(draft.cob_loc, f'{draft.prefix}COB-ID {hex_cob(cob)} is already used by {used[cob].label}')
        else:
            used[cob] = draft
