"""What a person reads first: one verdict line, the findings grouped (identical ones once, with
their count), errors first, each at the log's own clock and at the time since its first frame."""
from __future__ import annotations

import datetime
from dataclasses import dataclass, field

from drive_bridge.bag.diagnose.model import SEVERITY_ORDER, Finding, Severity

VERDICT_ITEMS = 3  # problems the verdict line names; the rest are counted


@dataclass
class Group:
    """Identical findings (severity, kind, node, what, cause): one line, ×count."""

    findings: list[Finding] = field(default_factory=list)

    @property
    def first(self) -> Finding:
        return self.findings[0]

    @property
    def count(self) -> int:
        return len(self.findings)


def group(findings: list[Finding]) -> list[Group]:
    """Errors, then warnings, then info; each kind in the order it first happened."""
    groups: dict[tuple[object, ...], Group] = {}
    for f in sorted(findings, key=lambda f: (f.time, f.seq)):
        groups.setdefault((f.severity, f.kind, f.node, f.what, f.cause), Group()).findings.append(f)
    return sorted(groups.values(), key=lambda g: (SEVERITY_ORDER[g.first.severity], g.first.time, g.first.seq))


def verdict(groups: list[Group], timing_note: str = '') -> str:
    """'2 errors: node 2 booted late; SDO server of node 3 sent invalid frames' (+ the warnings' count)."""
    errors = _headlines(g for g in groups if g.first.severity is Severity.ERROR)
    warnings = _headlines(g for g in groups if g.first.severity is Severity.WARNING)
    n_errors = sum(g.count for g in groups if g.first.severity is Severity.ERROR)  # as the badges count
    n_warnings = sum(g.count for g in groups if g.first.severity is Severity.WARNING)
    if errors:
        text = f'{_count(n_errors, "error")}: {_list(errors)}'
        if warnings:
            text += f'; and {_count(n_warnings, "warning")}'
    elif warnings:
        text = f'no errors, {_count(n_warnings, "warning")}: {_list(warnings)}'
    else:
        text = 'no problems found'
    return text + (f' ({timing_note})' if timing_note else '')


def _headlines(groups: object) -> list[str]:
    out: list[str] = []
    for g in groups:  # type: ignore[attr-defined]
        line = g.first.headline + (f' (×{g.count})' if g.count > 1 else '')
        if line not in out:
            out.append(line)
    return out


def _count(n: int, word: str) -> str:
    return f'{n} {word}' + ('s' if n != 1 else '')


def _list(items: list[str]) -> str:
    shown = '; '.join(items[:VERDICT_ITEMS])
    return shown + (f'; {len(items) - VERDICT_ITEMS} more' if len(items) > VERDICT_ITEMS else '')


def clock(t0: float, rel: float, timed: bool) -> str:
    """The log's own clock at ``rel`` s after its first frame: a wall-clock time for epoch time
    stamps (candump -L, bags; UTC), else the log's seconds (a trace counting from its start)."""
    if not timed:
        return '-'
    t = t0 + rel
    if t0 >= 1e9:
        stamp = datetime.datetime.fromtimestamp(t, datetime.UTC)
        return stamp.strftime('%H:%M:%S.%f')[:-3]
    return f'{t:.3f} s'


def when(t0: float, rel: float, timed: bool) -> str:
    """'12:00:01.234 (+1.234 s)', or '-' for a log without time stamps."""
    return f'{clock(t0, rel, timed)} (+{rel:.3f} s)' if timed else '-'
