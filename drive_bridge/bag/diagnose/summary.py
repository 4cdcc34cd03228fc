"""The short text summary printed on stdout."""
from __future__ import annotations

from typing import Any

from drive_bridge.bag.diagnose.model import Finding, Severity

MAX_LINES = 15


def summary(data: dict[str, Any], findings: list[Finding]) -> str:
    rec = data['recording']
    counts = data['summary']
    nodes = ', '.join(str(n['node']) + (f' ({n["name"]})' if n['name'] else '')
                      for n in data['nodes'] if n['frames_sent'])
    lines = [f'{rec["path"]}: {rec["format"]}, {rec["frames"]} frames, {rec["duration_s"]:.1f} s',
             f'nodes: {nodes or "none"}',
             f'NMT: {data["nmt"]["commands"]} commands ({data["nmt"]["invalid_commands"]} invalid), '
             f'{data["nmt"]["boot_ups"]} boot-ups ({data["nmt"]["unexpected_restarts"]} unexpected); '
             f'SDO: {len(data["sdo"]["transactions"])} transactions; EMCY: {len(data["emcy"])}; '
             f'SYNC: {data["sync"]["count"]}',
             f'findings: {counts["error"]} errors, {counts["warning"]} warnings, {counts["info"]} info']
    ranked = [f for f in findings if f.severity is Severity.ERROR] + \
             [f for f in findings if f.severity is Severity.WARNING]
    lines += [f'  {f}' for f in ranked[:MAX_LINES]]
    if len(ranked) > MAX_LINES:
        lines.append(f'  ... {len(ranked) - MAX_LINES} more in the report')
    return '\n'.join(lines)
