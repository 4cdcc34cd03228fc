"""The corpus of real CAN logs (test/data/traces/expectations.yaml) and how a tool's findings are
scored against what an expert reads in each log: right, found with a wrong cause, missed, and
false findings. Used by test_diagnose_corpus.py (drive-bridge) and bench/diagnose_lens.py (both
drive-bridge and canopen-lens, side by side)."""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

HERE = Path(__file__).resolve().parent
TRACES = HERE / 'data' / 'traces'
SHARED = HERE.parents[1] / 'shared' / 'realdata' / 'traces'
EXPECTATIONS = TRACES / 'expectations.yaml'
PROBLEMS = ('error', 'warning')
LENS_NOTES = ('parse_errors',)  # lens' notes about its own reading, not about the bus


def corpus() -> list[dict[str, Any]]:
    logs: list[dict[str, Any]] = yaml.safe_load(EXPECTATIONS.read_text(encoding='utf-8'))['logs']
    return logs


def path_of(log: dict[str, Any]) -> Path:
    return (TRACES if log['dir'] == 'test' else SHARED) / log['file']


@dataclass
class Found:
    """One finding of either tool, in a common shape."""

    tool: str
    kind: str
    node: int | None
    severity: str
    text: str
    outcome: str = ''


@dataclass
class Score:
    right: list[str] = field(default_factory=list)
    wrong: list[str] = field(default_factory=list)
    missed: list[str] = field(default_factory=list)
    false: list[str] = field(default_factory=list)  # 'kind node N: text' of each false finding (grouped)


def ours_found(data: dict[str, Any]) -> list[Found]:
    return [Found('ours', f['kind'], f['node'], f['severity'], f'{f["what"]} {f["cause"]}', f['outcome'])
            for f in data['findings']]


def lens_found(data: dict[str, Any]) -> list[Found]:
    out = [Found('lens', f['type'], f['node'], f['severity'], f'{f["title"]} {f["what"]}')
           for f in data.get('all_findings', []) if f['type'] not in LENS_NOTES]
    out += [Found('lens', 'node-status', n['node'], 'info', ' '.join([n['headline'], *n.get('details', [])]))
            for n in data.get('nodes', [])]
    return out


def _matches(matcher: dict[str, Any], found: Found) -> bool:
    kind = matcher.get('kind', matcher.get('type'))
    if kind is not None and found.kind != kind:
        return False
    if 'node' in matcher and found.node != matcher['node']:
        return False
    if 'severity' in matcher and found.severity != matcher['severity']:
        return False
    if 'text' in matcher and not re.search(matcher['text'], found.text):
        return False
    return not ('outcome' in matcher and not re.search(matcher['outcome'], found.outcome))


def _state_matches(matcher: dict[str, Any], data: dict[str, Any]) -> bool:
    want = matcher['state']
    return any(a['node'] == want['node'] and (a['state'] == want['state'] or
                                              any(t['to'] == want['state'] for t in a['transitions']))
               for a in data.get('cia402', []))


def score(log: dict[str, Any], tool: str, found: list[Found], data: dict[str, Any]) -> Score:
    """Each event right / wrong / missed; every error or warning no event or tolerance explains is false."""
    result = Score()
    used: set[int] = set()
    for event in log.get('events') or []:
        right, wrong = event.get(tool), event.get(f'{tool}_wrong')
        if right is not None and 'state' in right:
            (result.right if tool == 'ours' and _state_matches(right, data) else result.missed).append(event['id'])
            continue
        hits = [i for i, f in enumerate(found) if right is not None and _matches(right, f)]
        if hits:
            result.right.append(event['id'])
            used.update(hits)
            continue
        wrongs = [i for i, f in enumerate(found) if wrong is not None and _matches(wrong, f)]
        if wrongs:
            result.wrong.append(event['id'])
            used.update(wrongs)
        else:
            result.missed.append(event['id'])
    tolerated = [t for t in log.get('tolerated') or [] if t['tool'] == tool]
    false = [t for t in log.get('false') or [] if t['tool'] == tool]
    groups: dict[str, str] = {}  # (kind, node) -> the first one's text: one false finding per kind and node
    for i, f in enumerate(found):
        flagged = any(_matches(m, f) for m in false)
        if flagged or (f.severity in PROBLEMS and i not in used and not any(_matches(m, f) for m in tolerated)):
            groups.setdefault(f'{f.kind} node {f.node}', f.text[:90])
    result.false = [f'{key}: {text}' for key, text in groups.items()]
    return result


def check_facts(log: dict[str, Any], data: dict[str, Any]) -> list[str]:
    """drive-bridge's JSON against the log's `facts`: the problems, as text ('' when all hold)."""
    problems = []
    facts = log.get('facts') or {}
    if 'timebase' in facts and data['recording']['timebase'] != facts['timebase']:
        problems.append(f'time base {data["recording"]["timebase"]!r}, expected {facts["timebase"]!r}')
    if 'commanded_boot_ups' in facts and data['nmt']['commanded_boot_ups'] != facts['commanded_boot_ups']:
        problems.append(f'{data["nmt"]["commanded_boot_ups"]} commanded boot-ups, '
                        f'expected {facts["commanded_boot_ups"]}')
    for want in facts.get('sdo', []):
        if not any(t['node'] == want['node'] and t['object'].startswith(want['object'])
                   and t['status'] == want['status'] for t in data['sdo']['transactions']):
            problems.append(f'no SDO {want}')
    return problems
