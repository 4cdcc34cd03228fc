"""The boot SDO list (``sdo:``): lely's ``{index, sub_index, value}`` items, checked
against the node's object dictionary so a typo fails at load time, not at boot."""
from __future__ import annotations

from typing import Any

from canopen import ObjectDictionary

from drive_bridge.config import keys
from drive_bridge.config.errors import Issues, Loc
from drive_bridge.config.odcheck import convert_value, is_writable, lookup, var_ref
from drive_bridge.config.reader import Section, to_int
from drive_bridge.model import SdoWriteItem


def read_index(sec: Section) -> tuple[int | None, int | None]:
    """(index, sub-index) of an item; lely spells the sub-index ``sub_index``, others ``subindex``."""
    index = None
    if sec.require('index', 'an object index such as 0x6060'):
        index = to_int(sec.issues, sec.get('index'), sec.loc('index'), lo=0x0001, hi=0xFFFF, allow_str=True)
    if 'sub_index' in sec and 'subindex' in sec:
        sec.issues.error(sec.loc('subindex'), f'give either sub_index or subindex, not both '
                                              f'({sec.loc("sub_index").path})')
    key = 'subindex' if 'subindex' in sec else 'sub_index'
    subindex = to_int(sec.issues, sec.get(key, 0), sec.loc(key), lo=0, hi=0xFF, allow_str=True)
    return index, subindex


def parse_boot_sdo(issues: Issues, items: list[tuple[Loc, Any]], od: ObjectDictionary | None,
                   eds_name: str, file: str) -> tuple[SdoWriteItem, ...]:
    """The SDO writes in file order; with ``od`` None only their shape is checked."""
    writes = []
    for loc, value in items:
        sec = Section.of(issues, value, loc, 'a mapping {index, sub_index, value}')
        if sec is None:
            continue
        sec.check_keys(keys.SDO_ITEM)
        index, subindex = read_index(sec)
        has_value = sec.require('value', 'the value to write')
        if index is None or subindex is None or not has_value or od is None:
            continue
        found = lookup(od, eds_name, index, subindex)
        if found.var is None:
            issues.error(loc, found.problem)
            continue
        var = found.var
        if not is_writable(var):
            issues.error(loc, f'{var_ref(var)} is read-only (access {var.access_type}) in {eds_name}')
            continue
        converted, problem = convert_value(var, sec.get('value'), eds_name)
        if converted is None:
            issues.error(sec.loc('value'), f'{problem} for {var_ref(var)}')
            continue
        writes.append(SdoWriteItem(index, subindex, converted, where=f'{file}: {loc.path}'))
    return tuple(writes)
