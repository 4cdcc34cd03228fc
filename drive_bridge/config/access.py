"""The ``access`` section: what ROS clients may write, as an :class:`AccessConfig`.

Object rules (``sdo_read``, ``sdo_write``): ``true`` (every object), ``false`` or ``[]`` (none),
a list of indices and ranges for every node (``["0x6000-0x6FFF", 0x2000]``), or a mapping of
node (name or id) -> such a list with ``default`` for the others. Node rules (``nmt``,
``store_restore``, ``param_*``): ``true`` (any node), ``false``, ``configured``, or a list of
node names and ids. Node keys are YAML integers, so this section reads raw mappings.
"""
from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from drive_bridge.access_rules import (
    EVERY_OBJECT,
    AccessConfig,
    NodeRule,
    ObjectRange,
    ObjectRule,
    SafetyAllowance,
    safety_name,
)
from drive_bridge.config.errors import Issues, Loc
from drive_bridge.config.reader import Section, describe, parse_int_text, suggestion

ACCESS = ('read_only', 'sdo_read', 'sdo_write', 'store_restore', 'nmt', 'param_read', 'param_write', 'param_save',
          'safety_objects')
OBJECT_RULES = ('sdo_read', 'sdo_write')
NODE_RULES = ('store_restore', 'nmt', 'param_read', 'param_write', 'param_save')
WRITE_RULES = ('sdo_write', 'store_restore', 'nmt', 'param_write', 'param_save')
_RANGE = re.compile(r'^\s*(\w+)\s*(?:-\s*(\w+)\s*)?$')
T = TypeVar('T')
SafetyItems = tuple[tuple[ObjectRange, ...], frozenset[str]]  # objects and parameter names
_RANGE_HINT = 'an index (0x6040) or a range "0x6000-0x6FFF"'


def _index(text: str) -> int | None:
    number = parse_int_text(text, allow_str=True)
    return number if number is not None and 0 <= number <= 0xFFFF else None


def _range(issues: Issues, item: Any, loc: Loc) -> ObjectRange | None:
    if isinstance(item, int) and not isinstance(item, bool):
        if 0 <= item <= 0xFFFF:
            return ObjectRange(item, item)
    elif isinstance(item, str) and (match := _RANGE.match(item)):
        first = _index(match.group(1))
        last = _index(match.group(2)) if match.group(2) else first
        if first is not None and last is not None:
            if first <= last:
                return ObjectRange(first, last)
            issues.error(loc, f'range {item!r} ends before it starts; write the lower index first')
            return None
    issues.error(loc, f'expected {_RANGE_HINT} within 0x0000..0xFFFF, got {describe(item)}')
    return None


def _ranges(issues: Issues, value: Any, loc: Loc) -> tuple[ObjectRange, ...]:
    if value is True:
        return EVERY_OBJECT
    if value is False or value is None:
        return ()
    if not isinstance(value, list):
        issues.error(loc, f'expected true, false or a list of {_RANGE_HINT}, got {describe(value)}')
        return ()
    found = (_range(issues, item, loc.item(i)) for i, item in enumerate(value))
    return tuple(r for r in found if r is not None)


def _node_id(issues: Issues, key: Any, loc: Loc, ids: Mapping[str, int]) -> int | None:
    """A node named by its configured name or by its id (1..127, configured or not)."""
    if isinstance(key, str) and key in ids:
        return ids[key]
    number = key if isinstance(key, int) and not isinstance(key, bool) else None
    if number is not None and 1 <= number <= 127:
        return number
    names = ', '.join(ids) or 'none'
    hint = suggestion(key, list(ids)) if isinstance(key, str) else ''
    issues.error(loc, f'expected a node name or id 1..127, got {describe(key)}{hint}; the nodes are: {names}')
    return None


def _per_node(issues: Issues, value: Mapping[Any, Any], loc: Loc, ids: Mapping[str, int],
              parse: Callable[[Issues, Any, Loc], T], default: T) -> tuple[T, dict[int, T]]:
    """A mapping of node (name or id) -> item, with ``default`` for the others."""
    nodes: dict[int, T] = {}
    for key, item in value.items():
        where = loc.key(key)
        if key == 'default':
            default = parse(issues, item, where)
            continue
        node_id = _node_id(issues, key, where, ids)
        if node_id is None:
            continue
        if node_id in nodes:
            issues.error(where, f'node {node_id} is given twice (by name and by id)')
        nodes[node_id] = parse(issues, item, where)
    return default, nodes


def _object_rule(issues: Issues, value: Any, loc: Loc, ids: Mapping[str, int], base: ObjectRule) -> ObjectRule:
    if not isinstance(value, Mapping):
        return ObjectRule(_ranges(issues, value, loc), given=True)
    default, nodes = _per_node(issues, value, loc, ids, _ranges, base.default)
    return ObjectRule(default, nodes, given=True)


def _node_rule(issues: Issues, value: Any, loc: Loc, ids: Mapping[str, int]) -> NodeRule:
    if value is True:
        return NodeRule(any_node=True, given=True)
    if value is False or value is None:
        return NodeRule(given=True)
    if value == 'configured':
        return NodeRule(configured=True, given=True)
    if not isinstance(value, list):
        issues.error(loc, f"expected true, false, 'configured' or a list of node names and ids, got {describe(value)}")
        return NodeRule(given=True)
    found = (_node_id(issues, item, loc.item(i), ids) for i, item in enumerate(value))
    return NodeRule(node_ids=frozenset(n for n in found if n is not None), given=True)


def _is_range(text: str) -> bool:
    match = _RANGE.match(text)
    return match is not None and _index(match.group(1)) is not None and (
        match.group(2) is None or _index(match.group(2)) is not None)


def _safety_items(issues: Issues, value: Any, loc: Loc) -> SafetyItems:
    """Indices and ranges (objects) and vendor parameter names, mixed in one list."""
    if value is False or value is None:
        return (), frozenset()
    if not isinstance(value, list):
        issues.error(loc, f'expected a list of object indices ("0x6007"), ranges and vendor parameter names '
                          f'("p8641"), or true/false, got {describe(value)}')
        return (), frozenset()
    ranges: list[ObjectRange] = []
    names: set[str] = set()
    for i, item in enumerate(value):
        if isinstance(item, str) and not _is_range(item):
            if not item.strip():
                issues.error(loc.item(i), 'expected an object index or a parameter name, got an empty string')
            else:
                names.add(safety_name(item))
            continue
        found = _range(issues, item, loc.item(i))
        if found is not None:
            ranges.append(found)
    return tuple(ranges), frozenset(names)


def _safety(issues: Issues, value: Any, loc: Loc, ids: Mapping[str, int]) -> SafetyAllowance:
    if value is True:
        return SafetyAllowance(every=True)
    if not isinstance(value, Mapping):
        return SafetyAllowance(default=_safety_items(issues, value, loc))
    nothing: SafetyItems = ((), frozenset())
    default, nodes = _per_node(issues, value, loc, ids, _safety_items, nothing)
    return SafetyAllowance(default=default, nodes=nodes)


def parse_access(sec: Section | None, ids: Mapping[str, int]) -> AccessConfig:
    """The ``access`` section (None: the defaults); ``ids``: configured node name -> id."""
    base = AccessConfig()
    if sec is None:
        return base
    sec.check_keys(ACCESS)
    rules: dict[str, Any] = {'read_only': sec.get_bool('read_only', base.read_only)}
    for key in OBJECT_RULES:
        if key in sec:
            rules[key] = _object_rule(sec.issues, sec.get(key), sec.loc(key), ids, getattr(base, key))
    for key in NODE_RULES:
        if key in sec:
            rules[key] = _node_rule(sec.issues, sec.get(key), sec.loc(key), ids)
    if 'safety_objects' in sec:
        rules['safety_objects'] = _safety(sec.issues, sec.get('safety_objects'), sec.loc('safety_objects'), ids)
    if rules['read_only']:
        for key in WRITE_RULES:
            if key in sec:
                sec.issues.warn(sec.loc(key), 'has no effect: access.read_only refuses every write')
    return AccessConfig(**rules)
