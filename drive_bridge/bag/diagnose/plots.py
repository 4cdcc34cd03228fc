"""The report's plots as inline SVG (``svgchart``: no matplotlib, no numpy). A plot gets at
most about one point per pixel of its width: a long recording's bus load keeps each plotted
bin's peak, its following error each bin's extremes, so what matters stays visible."""
from __future__ import annotations

from collections.abc import Sequence

from drive_bridge.bag.diagnose.busload import BIN_S
from drive_bridge.bag.diagnose.engine import Diagnosis
from drive_bridge.bag.diagnose.svgchart import Chart
from drive_bridge.cia402.statemachine import State

MIN_SPAN_S = 1.0  # a recording shorter than this (or without time stamps) gets tables, no time plots
MAX_POINTS = 1000  # per series: more than the plot's width in pixels shows nothing more
HISTOGRAM_BINS = 80


def worth_plotting(d: Diagnosis) -> bool:
    """Time plots say something only over a recorded time base of some length."""
    return d.ctx.timing and d.duration >= MIN_SPAN_S


def _peaks(values: Sequence[int], step: int, scale: float) -> list[float]:
    return [max(values[i:i + step]) * scale for i in range(0, len(values), step)]


def _envelope(times: Sequence[float], values: Sequence[float]) -> tuple[list[float], list[float]]:
    """At most 2 x MAX_POINTS points: per bucket its first time with the minimum and the maximum."""
    step = max(1, -(-len(values) // MAX_POINTS))
    if step == 1:
        return list(times), list(values)
    xs: list[float] = []
    ys: list[float] = []
    for i in range(0, len(values), step):
        chunk = values[i:i + step]
        low, high = min(chunk), max(chunk)
        xs += [times[i], times[min(i + step, len(times)) - 1]]
        ys += [low, high] if chunk.index(low) <= chunk.index(high) else [high, low]
    return xs, ys


def busload(d: Diagnosis) -> str:
    load = d.busload
    step = max(1, -(-len(load.nominal) // MAX_POINTS))
    xs = [i * BIN_S for i in range(0, len(load.nominal), step)]
    scale = 1.0 / BIN_S / (load.bitrate / 100 if load.bitrate else 1000)
    nominal = _peaks(load.nominal, step, scale)
    stuffed = _peaks(load.stuffed, step, scale)
    chart = Chart(f'Bus load ({BIN_S * 1000:.0f} ms bins' + (', peak per plotted point)' if step > 1 else ')'),
                  'time [s]', f'load [% of {load.bitrate // 1000} kbit/s]' if load.bitrate else 'kbit/s')
    if xs:  # the last bin holds until its end
        xs.append(len(load.nominal) * BIN_S)
        nominal.append(nominal[-1])
        stuffed.append(stuffed[-1])
    chart.step(xs, nominal, 'C0', 'nominal bits', fill=True)
    chart.step(xs, [a + b for a, b in zip(nominal, stuffed)], 'C3', 'with worst-case stuff bits', width=0.8)
    return chart.render()


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
    chart = Chart('Nodes: alive by heartbeat (green) / guarding (cyan); grey lines: NMT commands to all',
                  'time [s]', height=int(100 * max(1.6, 0.35 * len(nodes) + 1.0)),
                  xlim=(0.0, max(d.duration, 0.01)), ylim=(-0.7, len(nodes) - 0.3),
                  yticks=[(row, d.ctx.label(n)) for row, n in enumerate(nodes)])
    t0 = d.t0
    chart.vlines(sorted({e.time for e in d.nmt.events if e.kind == 'command' and e.node is None}))
    for row, node in enumerate(nodes):
        live = d.liveness.nodes.get(node)
        if live is not None:
            for times, period, color in ((live.heartbeats, live.period, 'C2'),
                                         (live.reply_times, live.guard_period, 'C9')):
                if times:
                    chart.bars(_alive_runs([t - t0 for t in times], period or 1.0), row, 0.6, color)
        boots = [t - t0 for t in d.nmt.boot_ups.get(node, [])]
        chart.markers(boots, [row] * len(boots), '^', 'C0', 'boot-up' if row == 0 else None)
        commands = [e.time for e in d.nmt.events if e.kind == 'command' and e.node == node]
        chart.markers(commands, [row + 0.35] * len(commands), '|', 'k', 'NMT command to the node' if row == 0 else None)
        emcys = [r.time for r in d.emcy.records if r.node == node and not r.event.is_reset]
        chart.markers(emcys, [row] * len(emcys), 'x', 'C3', 'EMCY' if row == 0 else None, size=8)
    return chart.render()


def sync_histogram(d: Diagnosis) -> str:
    periods = [p * 1000 for p in d.sync.periods]
    low, high = min(periods), max(periods)
    width = (high - low) / HISTOGRAM_BINS or 1e-3
    counts = [0] * HISTOGRAM_BINS
    for period in periods:
        counts[min(int((period - low) / width), HISTOGRAM_BINS - 1)] += 1
    chart = Chart('SYNC period histogram', 'SYNC period [ms]', 'count', log_y=True)
    chart.columns([low + i * width for i in range(HISTOGRAM_BINS + 1)], counts, 'C0')
    if d.sync.nominal:
        chart.vlines([d.sync.nominal * 1000], 'C3', 'nominal', width=1.0)
    return chart.render()


def cia402_states(d: Diagnosis) -> str:
    axes = sorted(d.cia402.axes.values(), key=lambda a: (a.node, a.slot))
    states = list(State)
    chart = Chart('CiA 402 state per axis', 'time [s]', height=300, xlim=(0.0, max(d.duration, 0.01)),
                  ylim=(min(int(s) for s in states) - 0.5, max(int(s) for s in states) + 0.5),
                  yticks=[(int(s), s.label) for s in states])
    for n, axis in enumerate(axes):
        if not axis.transitions:
            continue
        xs = [t for t, _f, _s in axis.transitions] + [d.duration]
        ys = [float(int(s)) for _t, _f, s in axis.transitions]
        ys.append(ys[-1])
        joint = d.ctx.joint(axis.node, axis.slot)
        chart.step(xs, ys, f'C{n % 10}', f'node {axis.node} axis {axis.slot + 1}' + (f' ({joint})' if joint else ''),
                   width=1.5)
    return chart.render()


def following_error(d: Diagnosis) -> str:
    chart = Chart('Following error', 'time [s]', 'demand - actual [counts]')
    n = 0
    for (node, slot), axis in sorted(d.following.axes.items()):
        if not axis.errors:
            continue
        joint = d.ctx.joint(node, slot)
        xs, ys = _envelope(axis.times, axis.errors)
        chart.line(xs, ys, f'C{n % 10}', f'node {node} axis {slot + 1}' + (f' ({joint})' if joint else ''), width=0.8)
        n += 1
    return chart.render()
