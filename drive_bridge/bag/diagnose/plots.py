"""The report's plots, drawn with matplotlib and returned as inline SVG (no external
references: the XML prolog, DOCTYPE, metadata and namespace URLs are dropped, which inline SVG
in HTML5 does not need). matplotlib is imported when the first plot is drawn: a report whose
sections have nothing worth a plot (a short excerpt) does not pay for it."""
from __future__ import annotations

import io
import re
from typing import TYPE_CHECKING, Any

from drive_bridge.bag.diagnose.busload import BIN_S
from drive_bridge.bag.diagnose.engine import Diagnosis
from drive_bridge.cia402.statemachine import State

if TYPE_CHECKING:
    from matplotlib.figure import Figure

MIN_SPAN_S = 1.0  # a recording shorter than this (or without time stamps) gets tables, no time plots

MAX_POINTS = 3000
_STRIP = [re.compile(r'<\?xml[^>]*\?>\s*'), re.compile(r'<!DOCTYPE[^>]*>\s*'),
          re.compile(r'<metadata>.*?</metadata>\s*', re.S), re.compile(r'\s+xmlns(:\w+)?="[^"]*"')]


def worth_plotting(d: Diagnosis) -> bool:
    """Time plots say something only over a recorded time base of some length."""
    return d.ctx.timing and d.duration >= MIN_SPAN_S


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def _svg(fig: Figure) -> str:
    plt = _pyplot()
    buffer = io.StringIO()
    with plt.rc_context({'svg.fonttype': 'none', 'svg.hashsalt': 'drive-bridge'}):
        fig.savefig(buffer, format='svg', bbox_inches='tight', metadata={'Date': None})
    plt.close(fig)
    text = buffer.getvalue()
    for pattern in _STRIP:
        text = pattern.sub('', text)
    return text


def _figure(height: float = 2.6) -> tuple[Figure, Any]:
    fig, ax = _pyplot().subplots(figsize=(9.5, height))
    ax.grid(True, alpha=0.3)
    return fig, ax


def busload(d: Diagnosis) -> str:
    fig, ax = _figure()
    load = d.busload
    step = max(1, len(load.nominal) // MAX_POINTS)
    xs = [i * BIN_S for i in range(0, len(load.nominal), step)]
    scale = 1.0 / BIN_S / (load.bitrate / 100 if load.bitrate else 1000)
    nominal = [max(load.nominal[i:i + step]) * scale for i in range(0, len(load.nominal), step)]
    stuffed = [max(load.stuffed[i:i + step]) * scale for i in range(0, len(load.stuffed), step)]
    ax.fill_between(xs, nominal, step='post', alpha=0.5, label='nominal bits')
    ax.step(xs, [a + b for a, b in zip(nominal, stuffed)], where='post', lw=0.8, color='C3',
            label='with worst-case stuff bits')
    ax.set_xlabel('time [s]')
    ax.set_ylabel(f'load [% of {load.bitrate // 1000} kbit/s]' if load.bitrate else 'kbit/s')
    ax.set_title(f'Bus load ({BIN_S * 1000:.0f} ms bins' + (', peak per plotted point)' if step > 1 else ')'))
    ax.legend(loc='upper right', fontsize=8)
    return _svg(fig)


def _alive_runs(times: list[float], period: float) -> list[tuple[float, float]]:
    """(start, width) of the stretches without a gap longer than twice the period."""
    limit = 2.0 * period + 0.02
    runs = []
    start = times[0]
    for a, b in zip(times, times[1:]):
        if b - a > limit:
            runs.append((start, max(a - start, 0.01)))
            start = b
    runs.append((start, max(times[-1] - start, 0.01)))
    return runs


def timeline(d: Diagnosis) -> str:
    """Per node seen: heartbeat / guarding runs as bars, boot-ups, NMT commands and EMCYs."""
    nodes = d.nodes_seen()
    fig, ax = _figure(max(1.6, 0.35 * len(nodes) + 1.0))
    t0 = d.t0
    for time in sorted({e.time for e in d.nmt.events if e.kind == 'command' and e.node is None}):
        ax.axvline(time, color='0.6', lw=0.5, zorder=0)
    for row, node in enumerate(nodes):
        live = d.liveness.nodes.get(node)
        if live is not None:
            for times, period, color in ((live.heartbeats, live.period, 'C2'),
                                         (live.reply_times, live.guard_period, 'C9')):
                if times:
                    ax.broken_barh(_alive_runs([t - t0 for t in times], period or 1.0), (row - 0.3, 0.6),
                                   color=color, alpha=0.5)
        boots = [t - t0 for t in d.nmt.boot_ups.get(node, [])]
        ax.plot(boots, [row] * len(boots), '^', color='C0', ms=7, label='boot-up' if row == 0 else None)
        commands = [e.time for e in d.nmt.events if e.kind == 'command' and e.node == node]
        ax.plot(commands, [row + 0.35] * len(commands), '|', color='k', ms=6,
                label='NMT command to the node' if row == 0 else None)
        emcys = [r.time for r in d.emcy.records if r.node == node and not r.event.is_reset]
        ax.plot(emcys, [row] * len(emcys), 'x', color='C3', ms=8, mew=2, label='EMCY' if row == 0 else None)
    ax.set_yticks(range(len(nodes)), [d.ctx.label(n) for n in nodes])
    ax.set_ylim(-0.7, len(nodes) - 0.3)
    ax.set_xlim(0, max(d.duration, 0.01))
    ax.set_xlabel('time [s]')
    ax.set_title('Nodes: alive by heartbeat (green) / guarding (cyan); grey lines: NMT commands to all')
    handles, _labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(loc='upper right', fontsize=8, ncols=3)
    return _svg(fig)


def sync_histogram(d: Diagnosis) -> str:
    fig, ax = _figure()
    periods = [p * 1000 for p in d.sync.periods]
    ax.hist(periods, bins=80, color='C0', log=True)
    if d.sync.nominal:
        ax.axvline(d.sync.nominal * 1000, color='C3', lw=1, label='nominal')
        ax.legend(fontsize=8)
    ax.set_xlabel('SYNC period [ms]')
    ax.set_ylabel('count')
    ax.set_title('SYNC period histogram')
    return _svg(fig)


def cia402_states(d: Diagnosis) -> str:
    axes = sorted(d.cia402.axes.values(), key=lambda a: (a.node, a.slot))
    fig, ax = _figure(3.0)
    for axis in axes:
        if not axis.transitions:
            continue
        xs = [t for t, _f, _s in axis.transitions] + [d.duration]
        ys = [int(s) for _t, _f, s in axis.transitions]
        ys.append(ys[-1])
        joint = d.ctx.joint(axis.node, axis.slot)
        ax.step(xs, ys, where='post', label=f'node {axis.node} axis {axis.slot + 1}' + (f' ({joint})' if joint else ''))
    ax.set_yticks([int(s) for s in State], [s.label for s in State], fontsize=7)
    ax.set_xlabel('time [s]')
    ax.set_title('CiA 402 state per axis')
    ax.legend(fontsize=8, loc='lower right')
    return _svg(fig)


def following_error(d: Diagnosis) -> str:
    fig, ax = _figure()
    for (node, slot), axis in sorted(d.following.axes.items()):
        if not axis.errors:
            continue
        step = max(1, len(axis.errors) // MAX_POINTS)
        joint = d.ctx.joint(node, slot)
        ax.plot(axis.times[::step], axis.errors[::step], lw=0.8,
                label=f'node {node} axis {slot + 1}' + (f' ({joint})' if joint else ''))
    ax.set_xlabel('time [s]')
    ax.set_ylabel('demand - actual [counts]')
    ax.set_title('Following error')
    ax.legend(fontsize=8)
    return _svg(fig)
