"""The self-contained HTML report: one file, inline CSS and SVG plots, no script, no network."""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from html import escape
from typing import Any

from drive_bridge.bag.diagnose import plots
from drive_bridge.bag.diagnose.engine import Diagnosis

MAX_ROWS = 2000  # longer tables are cut in the HTML (the JSON has every row)
CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:1.5em auto;max-width:1200px;
color:#222;padding:0 1em}
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}td,th{border:1px solid #ddd;padding:.2em .5em;
text-align:left;vertical-align:top}th{background:#f4f4f4}tr.error td{background:#fde8e8}
tr.warning td{background:#fff6db}.num{text-align:right;font-variant-numeric:tabular-nums}
.badge{display:inline-block;padding:.1em .6em;border-radius:1em;margin-right:.5em;font-weight:600}
.b-error{background:#f8b4b4}.b-warning{background:#fde68a}.b-info{background:#dbeafe}
svg{max-width:100%;height:auto}details{margin:.4em 0}summary{cursor:pointer;color:#345}
.muted{color:#777}.verdict{font-size:1.15em;font-weight:600;padding:.5em .8em;border-radius:.4em;margin:.6em 0}
.v-error{background:#fde8e8;border-left:.4em solid #e02424}.v-warning{background:#fff6db;border-left:.4em solid #d69e2e}
.v-ok{background:#e6f6ec;border-left:.4em solid #2f855a}
"""


def with_unit(column: str, value: float) -> str:
    """A number with its unit, by the JSON key's convention (``_s``, ``_ms``, ``_hz``, ``load``, ``bits_per_s``)."""
    if column.endswith('bits_per_s') or column.endswith('bits_per_s_worst_stuffing'):
        return f'{value / 1000:.1f} kbit/s'
    if 'load' in column:
        return f'{value:.1%}'
    if column.endswith('_hz'):
        return f'{value:.1f} Hz'
    if column.endswith('_ms'):
        return f'{value:.3f} ms'
    if column.endswith('_s') or column in ('time', 'last_time'):
        return f'{value * 1000:.3f} ms' if abs(value) < 1 and column not in ('time', 'last_time') else f'{value:.3f} s'
    return f'{value:.6g}'


def _cell(value: Any, column: str = '') -> str:
    if value is None:
        return ''
    if isinstance(value, float):
        return f'<td class="num">{escape(with_unit(column, value))}</td>'
    if isinstance(value, int):
        return f'<td class="num">{value}</td>'
    if isinstance(value, (list, tuple)):
        return f'<td>{"<br>".join(escape(str(v)) for v in value)}</td>'
    if isinstance(value, dict):
        return f'<td>{"<br>".join(f"{escape(str(k))}: {escape(str(v))}" for k, v in value.items())}</td>'
    return f'<td>{escape(str(value))}</td>'


def table(rows: Sequence[dict[str, Any]], columns: Sequence[str] | None = None,
          row_class: str | None = None) -> str:
    if not rows:
        return '<p class="muted">none</p>'
    columns = list(columns or rows[0].keys())
    head = ''.join(f'<th>{escape(c.replace("_", " "))}</th>' for c in columns)
    body = []
    for row in rows[:MAX_ROWS]:
        cls = f' class="{escape(str(row.get(row_class, "")))}"' if row_class else ''
        body.append(f'<tr{cls}>' + ''.join(_cell(row.get(c), c) or '<td></td>' for c in columns) + '</tr>')
    more = (f'<p class="muted">first {MAX_ROWS} of {len(rows)} rows; the JSON has all</p>'
            if len(rows) > MAX_ROWS else '')
    return f'<table><tr>{head}</tr>{"".join(body)}</table>{more}'


def _section(title: str, *parts: str) -> str:
    return f'<h2 id="{escape(title.lower().replace(" ", "-"))}">{escape(title)}</h2>' + ''.join(parts)


def _details(title: str, content: str, open_: bool = False) -> str:
    return f'<details{" open" if open_ else ""}><summary>{escape(title)}</summary>{content}</details>'


def _plot(draw: Any, d: Diagnosis) -> str:
    return f'<figure>{draw(d)}</figure>'


def render(d: Diagnosis, data: dict[str, Any]) -> str:
    rec = data['recording']
    summary = data['summary']
    badges = ''.join(f'<span class="badge b-{k}">{v} {k}</span>' for k, v in summary.items())
    timed = d.ctx.timing
    facts = [('file', rec['path']), ('format', rec['format']), ('frames', rec['frames']),
             ('duration', f'{rec["duration_s"]:.3f} s' if timed else '-'),
             ('time base', 'the log\'s own clock' if timed else
              'none: no time stamps' if d.timebase == 'none' else d.timebase),
             ('start', rec['start'] or ('the trace\'s own clock (s since it started)' if timed else '-')),
             ('config', data['inputs']['config'] or 'none'),
             ('EDS', ', '.join(f'node {k}: {v}' for k, v in data['inputs']['eds'].items()) or 'none'),
             ('error / extended / remote frames', f'{rec["error_frames"]} / {rec["extended_frames"]} / '
                                                  f'{rec["remote_frames"]}')]
    level = 'error' if summary['error'] else 'warning' if summary['warning'] else 'ok'
    grouped = [{**g, 'when': g['clock'] + (f' (+{g["time"]:.3f} s)' if timed else ''),
                'count': f'×{g["count"]}' if g['count'] > 1 else ''} for g in data['grouped']]
    parts: list[str] = [
        f'<h1>CANopen bus diagnosis: {escape(rec["path"].rsplit("/", 1)[-1])}</h1>',
        f'<p class="verdict v-{level}">{escape(data["verdict"])}</p>',
        f'<p>{badges}</p>',
        '<table>' + ''.join(f'<tr><th>{escape(k)}</th><td>{escape(str(v))}</td></tr>' for k, v in facts)
        + '</table>',
        _section('Findings', '<p class="muted">errors first; identical findings once, with their count; '
                 'time: the log\'s own clock (and since its first frame)</p>',
                 table(grouped, ['severity', 'when', 'count', 'node', 'joint', 'what', 'cause', 'outcome'],
                       row_class='severity')),
        _section('Nodes', table([_node_row(n) for n in data['nodes']]),
                 _addressed(data['nodes_addressed_only']),
                 _plot(plots.timeline, d) if d.nodes_seen() and plots.worth_plotting(d) else ''),
        _section('NMT and boot timeline',
                 f'<p>{data["nmt"]["commands"]} NMT commands ({data["nmt"]["invalid_commands"]} invalid), '
                 f'{data["nmt"]["boot_ups"]} boot-ups ({data["nmt"]["commanded_boot_ups"]} after an NMT reset, '
                 f'{data["nmt"]["unexpected_restarts"]} unexpected restarts)</p>',
                 _details('events', table(data['nmt']['events']))),
        _section('SDO transactions', _sdo_counts(data['sdo']['transactions']),
                 _details('log', table(data['sdo']['transactions']))),
        _section('EMCY', table(data['emcy'])),
        _section('CiA 402 axes', *_axes(d, data)),
        _section('SYNC', *_sync(d, data)),
        _section('Bus load', table([data['busload']]), _plot(plots.busload, d) if plots.worth_plotting(d) else
                 '<p class="muted">no plot: the log is shorter than 1 s or has no time stamps of its own</p>'),
        _section('PDOs', table(data['pdo'])),
        _section('Following error', *_following(d, data)),
        _section('COB-IDs', _details('frames per COB-ID', table([{'cob_id': k, 'frames': v}
                                                                  for k, v in data['cob_ids'].items()]))),
    ]
    return ('<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1"><title>Diagnosis: '
            f'{escape(rec["path"].rsplit("/", 1)[-1])}</title><style>{CSS}</style></head><body>'
            + ''.join(parts) + '<p class="muted">drive-bridge diagnose</p></body></html>\n')


def _node_row(node: dict[str, Any]) -> dict[str, Any]:
    row = {k: node[k] for k in ('node', 'name', 'family', 'frames_sent', 'identity', 'boot_ups', 'emcy',
                                'sdo_transactions')}
    row['node'] = f'node {node["node"]}'
    hb = node.get('heartbeat') or {}
    guard = node.get('guarding') or {}
    row['heartbeat'] = (f'{hb["count"]} × {hb["period_s"] * 1000:.0f} ms, {len(hb["gaps"])} gaps'
                        if hb.get('period_s') else f'{hb.get("count", 0)} frames')
    row['guarding'] = (f'{guard["requests"]} requests, {guard["replies"]} replies, '
                       f'{guard["unanswered"]} unanswered, {guard["toggle_errors"]} toggle errors'
                       if guard.get('requests') else '')
    return row


def _addressed(nodes: Iterable[int]) -> str:
    nodes = list(nodes)
    return (f'<p class="muted">addressed but never answered: {", ".join(map(str, nodes))}</p>' if nodes else '')


def _axes(d: Diagnosis, data: dict[str, Any]) -> list[str]:
    axes = data['cia402']
    if not axes:
        return ['<p class="muted">no statusword or controlword in the recording</p>']
    out = [table([{k: a[k] for k in ('node', 'slot', 'joint', 'state', 'commands', 'commands_not_followed')}
                  for a in axes])]
    if any(a['transitions'] for a in axes) and plots.worth_plotting(d):
        out.append(_plot(plots.cia402_states, d))
    for a in axes:
        out.append(_details(f'node {a["node"]} axis {a["slot"] + 1}: {len(a["transitions"])} transitions',
                            table(a['transitions'])))
    return out


def _sync(d: Diagnosis, data: dict[str, Any]) -> list[str]:
    sync = data['sync']
    if sync['count'] < 3 or not sync['nominal_s']:
        return [f'<p class="muted">{sync["count"]} SYNC frames' + ('' if d.ctx.timing else ', no time stamps') + '</p>']
    jitter = {k: f'{v * 1e6:.0f} µs' for k, v in sync['jitter_s'].items()}
    return [f'<p>{sync["count"]} SYNC frames, nominal period {sync["nominal_s"] * 1000:.3f} ms, '
            f'{sync["gaps"]} gaps</p>', table([jitter]),
            _plot(plots.sync_histogram, d) if plots.worth_plotting(d) else '']


def _following(d: Diagnosis, data: dict[str, Any]) -> list[str]:
    rows = data['following_error']
    if not rows:
        return ['<p class="muted">no axis with both a demand (0x6062 / 0x607A) and an actual position (0x6064)</p>']
    return [table(rows), _plot(plots.following_error, d)]


def _sdo_counts(rows: Sequence[dict[str, Any]]) -> str:
    aborted = sum(1 for t in rows if t['status'] == 'abort')
    unanswered = sum(1 for t in rows if t['status'] == 'no response')
    return f'<p>{len(rows)} transactions, {aborted} aborted, {unanswered} without response</p>'
