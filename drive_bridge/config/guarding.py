"""How the master supervises a node: heartbeat (0x1017) or CiA 301 node guarding
(``guard_time_ms`` -> 0x100C, ``life_time_factor`` -> 0x100D), never both.

A node's own key wins over one inherited from ``defaults`` here too, so ``defaults`` may give
every drive a heartbeat while one node without heartbeat is guarded.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from canopen import ObjectDictionary

from drive_bridge.config.errors import Loc
from drive_bridge.config.odcheck import is_writable, lookup, var_ref
from drive_bridge.config.reader import Section, parse_int_text

DEFAULT_HEARTBEAT_MS = 100
DEFAULT_LIFE_TIME_FACTOR = 3
GUARD_TIME = 0x100C
LIFE_TIME_FACTOR = 0x100D


@dataclass(frozen=True)
class Supervision:
    """The node's heartbeat producer time, or its guard time and life time factor (ms; 0 = off)."""

    heartbeat_producer_ms: int
    guard_time_ms: int = 0
    life_time_factor: int = 0

    @property
    def guarded(self) -> bool:
        return self.guard_time_ms > 0


def _guarding(node: Section) -> tuple[int, int]:
    """(guard time ms, life time factor) as the node's keys give them; (0, 0) = not guarded."""
    issues = node.issues
    before = issues.error_count
    guard = node.get_int('guard_time_ms', 0, lo=0, hi=0xFFFF) or 0
    guard_valid = issues.error_count == before
    if 'life_time_factor' not in node:
        return guard, DEFAULT_LIFE_TIME_FACTOR if guard else 0
    factor = node.get_int('life_time_factor', lo=1, hi=0xFF)
    if guard:
        return guard, factor or DEFAULT_LIFE_TIME_FACTOR
    if factor is not None and guard_valid and node.own('life_time_factor'):
        given = (f'guard_time_ms is 0 ({node.loc("guard_time_ms").path})' if 'guard_time_ms' in node
                 else 'guard_time_ms is not given')
        issues.error(node.loc('life_time_factor'), f'a life time factor without node guarding: {given}; '
                                                   'give guard_time_ms 1..65535 or remove life_time_factor')
    return 0, 0


def parse_supervision(node: Section, name: str, family: str = '', has_heartbeat: bool = True) -> Supervision:
    """Heartbeat or guarding of node ``name``; both > 0 at the same level is an error. A
    family without heartbeat must be guarded: no guard time is an error, and so is a
    heartbeat time the node gives itself (one from ``defaults`` does not apply to it)."""
    guard, factor = _guarding(node)
    if not has_heartbeat:
        if node.own('heartbeat_producer') and (node.get_int('heartbeat_producer', 0) or 0):
            node.issues.error(node.loc('heartbeat_producer'),
                              f"family '{family}' is supervised by node guarding, not heartbeat: supervise node "
                              f"'{name}' with guard_time_ms instead")
        elif not guard:
            node.issues.error(node.loc('family') if 'family' in node else node.where,
                              f"family '{family}' is supervised by node guarding: node '{name}' needs "
                              'guard_time_ms (e.g. 100) so that the bridge notices when it is lost')
        return Supervision(0, guard, factor)
    producer = node.get_int('heartbeat_producer', 0 if guard else DEFAULT_HEARTBEAT_MS, lo=0, hi=0xFFFF) or 0
    if not (guard and producer):
        return Supervision(producer, guard, factor)
    if node.own('guard_time_ms') and not node.own('heartbeat_producer'):
        return Supervision(0, guard, factor)  # the node's own guard time wins over the default heartbeat
    if node.own('heartbeat_producer') and not node.own('guard_time_ms'):
        return Supervision(producer)  # the node's own heartbeat wins over the default guard time
    node.issues.error(node.loc('guard_time_ms'),
                      f"heartbeat and node guarding exclude each other: node '{name}' has heartbeat_producer "
                      f'{producer} ({node.loc("heartbeat_producer").path}) and guard_time_ms {guard}; give '
                      'heartbeat_producer: 0 to guard the node, or guard_time_ms: 0 to use its heartbeat')
    return Supervision(producer)


def check_guarding_objects(node: Section, supervision: Supervision, od: ObjectDictionary, eds_name: str,
                           sdo_items: list[tuple[Loc, Any]]) -> None:
    """A guarded node needs writable 0x100C and 0x100D; a boot SDO to them is overridden
    (guarded) or has no master behind it (not guarded): both warnings."""
    issues = node.issues
    if supervision.guarded:
        problems = []
        for index in (GUARD_TIME, LIFE_TIME_FACTOR):
            found = lookup(od, eds_name, index, 0)
            if found.var is None:
                problems.append(found.problem)
            elif not is_writable(found.var):
                problems.append(f'{var_ref(found.var)} is read-only (access {found.var.access_type}) in {eds_name}')
        if problems:
            issues.error(node.loc('guard_time_ms'), 'node guarding writes 0x100C (guard time) and 0x100D (life time '
                                                    f'factor) at boot, but {"; ".join(problems)}')
    for loc, item in sdo_items:
        written = parse_int_text(item.get('index'), True) if isinstance(item, Mapping) else None
        if written not in (GUARD_TIME, LIFE_TIME_FACTOR):
            continue
        if supervision.guarded:
            issues.warn(loc, f'0x{written:04X} is written from guard_time_ms / life_time_factor by the node '
                             'guarding boot step after the boot SDOs; remove this item')
        elif parse_int_text(item.get('value'), True) != 0:
            issues.warn(loc, f'0x{written:04X} makes the node expect node guarding, but the master guards only nodes '
                             'with guard_time_ms; give guard_time_ms (and life_time_factor) instead')
