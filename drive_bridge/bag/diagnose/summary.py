"""The short text summary printed on stdout: the verdict line first, then the grouped errors
and warnings, each at the log's own clock and the time since its first frame, with units."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from drive_bridge.bag.diagnose.model import Severity
from drive_bridge.bag.diagnose.verdict import group, when

if TYPE_CHECKING:
    from drive_bridge.bag.diagnose.engine import Diagnosis

MAX_LINES = 15


def summary(data: dict[str, Any], d: Diagnosis) -> str:
    rec = data['recording']
    nodes = ', '.join(str(n['node']) + (f' ({n["name"]})' if n['name'] else '')
                      for n in data['nodes'] if n['frames_sent'])
    sync = data['sync']
    period = f' every {sync["nominal_s"] * 1000:.2f} ms' if sync['nominal_s'] else ''
    duration = f'{rec["duration_s"]:.3f} s' if d.ctx.timing else 'no time stamps' \
        if d.timebase == 'none' else f'{rec["duration_s"]:.3f} s ({d.timebase})'
    lines = [f'verdict: {data["verdict"]}',
             f'{rec["path"]}: {rec["format"]}, {rec["frames"]} frames, {duration}'
             + (f', from {rec["start"]}' if rec['start'] else ''),
             f'nodes: {nodes or "none"}',
             f'NMT: {data["nmt"]["commands"]} commands ({data["nmt"]["invalid_commands"]} invalid), '
             f'{data["nmt"]["boot_ups"]} boot-ups ({data["nmt"]["unexpected_restarts"]} unexpected); '
             f'SDO: {len(data["sdo"]["transactions"])} transactions; EMCY: {len(data["emcy"])}; '
             f'SYNC: {sync["count"]} frames{period}']
    counts = data['summary']
    lines.append(f'findings: {counts["error"]} errors, {counts["warning"]} warnings, {counts["info"]} info')
    ranked = [g for g in group(d.ctx.findings) if g.first.severity is not Severity.INFO]
    for g in ranked[:MAX_LINES]:
        f = g.first
        cause = f': {f.cause}' if f.cause else ''
        outcome = f' [{f.outcome}]' if f.outcome else ''
        times = f' ×{g.count}' if g.count > 1 else ''
        lines.append(f'  {f.severity.value.upper():7} {when(d.t0, f.time, d.ctx.timing)}  {f.where()}: '
                     f'{f.what}{cause}{outcome}{times}')
    if len(ranked) > MAX_LINES:
        lines.append(f'  ... {len(ranked) - MAX_LINES} more in the report')
    return '\n'.join(lines)
