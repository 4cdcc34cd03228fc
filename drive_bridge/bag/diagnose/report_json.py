"""The diagnosis as JSON: the same content as the HTML report, for tools and CI."""
from __future__ import annotations

import datetime
from typing import Any

from drive_bridge.bag.diagnose.engine import Diagnosis
from drive_bridge.bag.diagnose.model import Severity
from drive_bridge.bag.diagnose.names import object_label
from drive_bridge.bag.diagnose.sdo import format_value
from drive_bridge.bag.diagnose.verdict import clock, group, verdict
from drive_bridge.cia402.modes import mode_name


def start_time(d: Diagnosis) -> str | None:
    """Wall-clock start when the trace's time base is epoch time (else traces count from 0)."""
    if d.t0 < 1e9:
        return None
    return datetime.datetime.fromtimestamp(d.t0, datetime.UTC).isoformat(timespec='milliseconds')


def node_rows(d: Diagnosis) -> list[dict[str, Any]]:
    rows = []
    for node in sorted(set(d.nodes_seen()) | set(d.ctx.nodes)):
        info = d.ctx.nodes.get(node)
        live = d.liveness.nodes.get(node)
        ident = d.identities.nodes.get(node)
        row: dict[str, Any] = {
            'node': node, 'name': info.name if info else '',
            'family': info.family.name if info and info.family else '',
            'frames_sent': d.frames_from(node), 'identity': ident.to_json() if ident else {},
            'boot_ups': len(d.nmt.boot_ups.get(node, [])),
            'emcy': sum(1 for r in d.emcy.records if r.node == node),
            'sdo_transactions': sum(1 for t in d.sdo.transactions if t.node == node)}
        if live is not None:
            row['heartbeat'] = {'count': len(live.heartbeats), 'period_s': live.period,
                                'producer_ms': live.producer_ms or None,
                                'gaps': [{'from': round(a, 6), 'to': round(b, 6), 'reboot': r}
                                         for a, b, r in live.gaps]}
            row['guarding'] = {'requests': len(live.guard_requests), 'replies': live.guard_replies,
                               'period_s': live.guard_period, 'unanswered': len(live.unanswered),
                               'toggle_errors': len(live.toggle_errors)}
        rows.append(row)
    return rows


def sdo_rows(d: Diagnosis) -> list[dict[str, Any]]:
    t0 = d.t0
    rows = []
    labels: dict[tuple[int, int, int], str] = {}  # a long log repeats few objects many times
    for txn in d.sdo.transactions:
        key = (txn.node, txn.index, txn.subindex)
        label = labels.get(key)
        if label is None:
            info = d.ctx.nodes.get(txn.node)
            label = labels[key] = object_label(info.od if info else None, txn.index, txn.subindex)
        rows.append({'time': round(txn.t_request - t0, 6), 'node': txn.node, 'object': label,
                     'access': 'write' if txn.write else 'read', 'status': txn.status,
                     'value': format_value(txn) if txn.data else None,
                     'latency_ms': round(txn.latency * 1000, 3) if txn.latency is not None else None,
                     'abort': f'0x{txn.abort:08X}' if txn.abort is not None else None,
                     'transfer': 'block' if txn.block else 'segmented' if txn.segmented else 'expedited'})
    return rows


def timing_note(d: Diagnosis) -> str:
    if d.ctx.timing:
        return ''
    return 'timing not judged: no time stamps' if d.timebase == 'none' else f'timing not judged: {d.timebase}'


def to_json(d: Diagnosis) -> dict[str, Any]:
    groups = group(d.ctx.findings)
    timed = d.ctx.timing
    return {
        'verdict': verdict(groups, timing_note(d)),
        'recording': {'path': d.path, 'format': d.format, 'frames': d.frames, 'duration_s': d.duration,
                      'start': start_time(d), 'timebase': d.timebase, 'error_frames': d.error_frames,
                      'extended_frames': d.extended_frames, 'remote_frames': d.remote_frames},
        'inputs': {'config': d.inputs.config_source or None,
                   'eds': {str(k): v for k, v in d.inputs.eds_names().items()}, 'bitrate': d.ctx.bitrate},
        'summary': {s.value: d.count(s) for s in Severity},
        'findings': [{**f.to_json(), 'clock': clock(d.t0, f.time, timed)} for f in d.findings],
        'grouped': [{**g.first.to_json(), 'clock': clock(d.t0, g.first.time, timed), 'count': g.count,
                     'last_time': round(g.findings[-1].time, 6)} for g in groups],
        'nodes': node_rows(d),
        'nodes_addressed_only': d.nodes_addressed_only(),
        'nmt': {'commands': d.nmt.commands, 'invalid_commands': d.nmt.invalid,
                'boot_ups': sum(len(v) for v in d.nmt.boot_ups.values()),
                'commanded_boot_ups': d.nmt.commanded_boots, 'unexpected_restarts': d.nmt.unexpected_boots,
                'events': [{'time': round(e.time, 6), 'node': e.node, 'kind': e.kind, 'text': e.text}
                           for e in d.nmt.events]},
        'sdo': {'transactions': sdo_rows(d), 'unpaired_responses': d.sdo.unpaired_responses},
        'emcy': [{'time': round(r.time, 6), 'node': r.node, 'code': f'0x{r.event.code:04X}',
                  'register': f'0x{r.event.register:02X}', 'text': r.text, 'severity': r.event.severity.value,
                  'joint': d.ctx.joint(r.node, r.event.slot)} for r in d.emcy.records],
        'cia402': [{'node': a.node, 'slot': a.slot, 'joint': d.ctx.joint(a.node, a.slot),
                    'state': a.state.label, 'commands': a.commands, 'commands_not_followed': a.failed,
                    'modes': [{'time': round(t, 6), 'mode': mode_name(m)} for t, m in a.modes],
                    'transitions': [{'time': round(t, 6), 'from': f.label, 'to': s.label} for t, f, s in a.transitions]}
                   for a in sorted(d.cia402.axes.values(), key=lambda a: (a.node, a.slot))],
        'sync': d.sync.to_json(),
        'busload': d.busload.to_json(),
        'pdo': d.pdo.rows(),
        'following_error': d.following.to_json(),
        'cob_ids': {f'0x{cob:03X}' + (' RTR' if rtr else ''): n for cob in range(2048)
                    for rtr, n in ((False, d.counts[cob]), (True, d.remote_counts[cob])) if n},
    }
