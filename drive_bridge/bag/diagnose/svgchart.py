"""A small chart as inline SVG for the report: axes with round ticks, step and line series,
filled steps, bars, markers, vertical lines and a legend. The report's five plots need no
more, and drawing them here costs milliseconds where matplotlib's import alone took 0.4 s.

Coordinates are data units; ``render()`` maps them into the plot area. No script, no
external reference, no ``xmlns`` (inline SVG in HTML5 does not need one).
"""
from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from html import escape

# matplotlib's default colour cycle (tab10), so the report keeps the colours people know
COLORS = {'C0': '#1f77b4', 'C1': '#ff7f0e', 'C2': '#2ca02c', 'C3': '#d62728', 'C4': '#9467bd',
          'C5': '#8c564b', 'C6': '#e377c2', 'C7': '#7f7f7f', 'C8': '#bcbd22', 'C9': '#17becf',
          'k': '#000000', 'grey': '#999999'}
FONT = 12  # px
CHAR_W = 0.6 * FONT  # the width of a character, for the margins (no font metrics here)


def color(name: str) -> str:
    return COLORS.get(name, name)


def nice_ticks(lo: float, hi: float, most: int = 7) -> list[float]:
    """Round tick values (1, 2, 2.5, 5 x 10^n apart) covering [lo, hi], at most ``most``."""
    span = hi - lo
    if not span > 0 or not math.isfinite(span):
        return [lo]
    magnitude = 10.0 ** math.floor(math.log10(span / most))
    step = next(m * magnitude for m in (1, 2, 2.5, 5, 10, 20) if span / (m * magnitude) <= most)
    first = math.ceil(lo / step - 1e-9) * step
    count = int((hi - first) / step + 1e-9) + 1
    return [first + i * step for i in range(count)]


def tick_label(value: float, step: float) -> str:
    """A tick value with the decimals its step needs (0.25 apart: two; 0.5: one; 100: none)."""
    digits = 0
    if step > 0:
        exponent = math.floor(math.log10(step))
        digits = max(0, -exponent + (1 if round(step / 10.0 ** exponent, 6) == 2.5 else 0))
    text = f'{value:.{digits}f}'
    return '0' if text.strip('-0.') == '' else text  # no "-0.00"


@dataclass
class _Series:
    kind: str  # 'step', 'line', 'fill', 'bars', 'columns', 'markers', 'vlines'
    xs: Sequence[float]
    ys: Sequence[float] = ()
    color: str = 'C0'
    label: str | None = None
    width: float = 1.0
    opacity: float = 1.0
    marker: str = 'o'
    size: float = 6.0
    bars: Sequence[tuple[float, float]] = ()  # (start, width) at y = ys[0], height = size (data units)


@dataclass
class Chart:
    """One plot: add series, then ``render()``; ``height`` in px, ``width`` 950 as the report's column."""

    title: str = ''
    xlabel: str = ''
    ylabel: str = ''
    height: int = 260
    width: int = 950
    log_y: bool = False
    xlim: tuple[float, float] | None = None
    ylim: tuple[float, float] | None = None
    yticks: list[tuple[float, str]] | None = None  # fixed ticks with labels (categories)
    series: list[_Series] = field(default_factory=list)

    # -- series ----------------------------------------------------------------------------
    def step(self, xs: Sequence[float], ys: Sequence[float], color: str = 'C0', label: str | None = None,
             fill: bool = False, width: float = 1.0, opacity: float = 1.0) -> None:
        """y holds from each x to the next (matplotlib's where='post')."""
        self.series.append(_Series('fill' if fill else 'step', xs, ys, color, label, width, opacity))

    def line(self, xs: Sequence[float], ys: Sequence[float], color: str = 'C0', label: str | None = None,
             width: float = 1.0) -> None:
        self.series.append(_Series('line', xs, ys, color, label, width))

    def bars(self, runs: Sequence[tuple[float, float]], y: float, height: float, color: str = 'C0',
             opacity: float = 0.5, label: str | None = None) -> None:
        """Horizontal bars (start, width) centred on y (a timeline row)."""
        self.series.append(_Series('bars', (), (y,), color, label, opacity=opacity, size=height, bars=runs))

    def columns(self, edges: Sequence[float], counts: Sequence[float], color: str = 'C0',
                label: str | None = None) -> None:
        """A histogram: counts[i] between edges[i] and edges[i + 1]."""
        self.series.append(_Series('columns', edges, counts, color, label))

    def markers(self, xs: Sequence[float], ys: Sequence[float], marker: str = 'o', color: str = 'C0',
                label: str | None = None, size: float = 7.0) -> None:
        """Markers: '^' triangle, '|' tick, 'x' cross, 'o' dot."""
        self.series.append(_Series('markers', xs, ys, color, label, marker=marker, size=size))

    def vlines(self, xs: Sequence[float], color: str = 'grey', label: str | None = None, width: float = 0.6) -> None:
        self.series.append(_Series('vlines', xs, (), color, label, width))

    # -- drawing ---------------------------------------------------------------------------
    def _limits(self) -> tuple[float, float, float, float]:
        xs: list[float] = []
        ys: list[float] = []
        for s in self.series:
            if s.kind == 'bars':
                xs += [a for a, _w in s.bars] + [a + w for a, w in s.bars]
                ys += [s.ys[0] - s.size / 2, s.ys[0] + s.size / 2]
            elif s.kind == 'columns':
                xs += [s.xs[0], s.xs[-1]] if s.xs else []
                ys += list(s.ys) + [0.0]
            else:
                xs += [min(s.xs), max(s.xs)] if s.xs else []
                if s.kind != 'vlines' and s.ys:
                    ys += [min(s.ys), max(s.ys)] + ([0.0] if s.kind == 'fill' else [])
        x0, x1 = self.xlim or ((min(xs), max(xs)) if xs else (0.0, 1.0))
        if self.ylim:
            y0, y1 = self.ylim
        elif self.log_y:
            positive = [y for y in ys if y > 0] or [1.0]
            y0, y1 = 10 ** math.floor(math.log10(min(positive))), 10 ** math.ceil(math.log10(max(positive) * 1.05))
        else:
            y0, y1 = (min(ys), max(ys)) if ys else (0.0, 1.0)
            pad = (y1 - y0) * 0.05 or 0.5
            y0, y1 = (0.0 if y0 == 0 else y0 - pad), y1 + pad  # a series from 0 (a load) stays on the axis
        if x1 <= x0:
            x1 = x0 + 1.0
        if y1 <= y0:
            y1 = y0 + 1.0
        return x0, x1, y0, y1

    def render(self) -> str:
        x0, x1, y0, y1 = self._limits()
        if self.yticks is not None:
            yticks = [(y, text) for y, text in self.yticks if y0 <= y <= y1]
        elif self.log_y:
            yticks = [(10.0 ** e, f'{10.0 ** e:g}') for e in range(round(math.log10(y0)), round(math.log10(y1)) + 1)]
        else:
            values = nice_ticks(y0, y1, 5)
            step = values[1] - values[0] if len(values) > 1 else 1.0
            yticks = [(v, tick_label(v, step)) for v in values]
        xvalues = nice_ticks(x0, x1, 10)
        xstep = xvalues[1] - xvalues[0] if len(xvalues) > 1 else 1.0
        left = 14 + (FONT + 6 if self.ylabel else 0) + CHAR_W * max((len(t) for _y, t in yticks), default=1)
        top, bottom, right = (26 if self.title else 10), 38 if self.xlabel else 22, 14
        pw, ph = self.width - left - right, self.height - top - bottom
        if self.log_y:
            ly0, ly1 = math.log10(y0), math.log10(y1)

            def py(y: float) -> float:
                return top + ph - (math.log10(max(y, y0)) - ly0) / (ly1 - ly0) * ph
        else:
            def py(y: float) -> float:
                return top + ph - (y - y0) / (y1 - y0) * ph

        def px(x: float) -> float:
            return left + (x - x0) / (x1 - x0) * pw

        clip = 'clip-' + (re.sub(r'[^a-z0-9]+', '-', self.title.lower()).strip('-') or 'plot')  # one per report
        out = [f'<svg viewBox="0 0 {self.width} {self.height}" width="{self.width}" height="{self.height}" '
               f'role="img" aria-label="{escape(self.title)}" font-family="sans-serif" font-size="{FONT}">',
               f'<defs><clipPath id="{clip}"><rect x="{left:.1f}" y="{top}" width="{pw:.1f}" '
               f'height="{ph}"/></clipPath></defs>']
        if self.title:
            out.append(f'<text x="{left + pw / 2:.1f}" y="{top - 9}" text-anchor="middle" font-size="{FONT + 1}">'
                       f'{escape(self.title)}</text>')
        grid = []
        for y, text in yticks:
            grid.append(f'M{left:.1f} {py(y):.1f}H{left + pw:.1f}')
            out.append(f'<text x="{left - 4:.1f}" y="{py(y) + 4:.1f}" text-anchor="end">{escape(text)}</text>')
        for x in xvalues:
            grid.append(f'M{px(x):.1f} {top}V{top + ph}')
            out.append(f'<text x="{px(x):.1f}" y="{top + ph + 14}" text-anchor="middle">'
                       f'{escape(tick_label(x, xstep))}</text>')
        out.append(f'<path d="{"".join(grid)}" stroke="#000" stroke-opacity="0.12" fill="none"/>')
        out.append(f'<g clip-path="url(#{clip})">')
        for s in self.series:
            out.append(self._series(s, px, py, y0))
        out.append('</g>')
        out.append(f'<rect x="{left:.1f}" y="{top}" width="{pw:.1f}" height="{ph}" fill="none" stroke="#444"/>')
        if self.xlabel:
            out.append(f'<text x="{left + pw / 2:.1f}" y="{self.height - 6}" text-anchor="middle">'
                       f'{escape(self.xlabel)}</text>')
        if self.ylabel:
            out.append(f'<text transform="translate({FONT + 2},{top + ph / 2:.1f}) rotate(-90)" '
                       f'text-anchor="middle">{escape(self.ylabel)}</text>')
        out.append(self._legend(left + pw, top))
        out.append('</svg>')
        return ''.join(out)

    @staticmethod
    def _series(s: _Series, fx: Callable[[float], float], fy: Callable[[float], float], y0: float) -> str:
        c = color(s.color)
        if s.kind in ('step', 'fill', 'line'):
            if not s.xs:
                return ''
            points = [f'{fx(s.xs[0]):.1f} {fy(s.ys[0]):.1f}']
            for i in range(1, len(s.xs)):
                x = fx(s.xs[i])
                if s.kind != 'line':
                    points.append(f'{x:.1f} {fy(s.ys[i - 1]):.1f}')
                points.append(f'{x:.1f} {fy(s.ys[i]):.1f}')
            d = 'M' + 'L'.join(points)
            if s.kind == 'fill':
                base = fy(max(y0, 0.0))
                return (f'<path d="{d}V{base:.1f}H{fx(s.xs[0]):.1f}Z" fill="{c}" fill-opacity="0.5" '
                        f'stroke="none"/>')
            return (f'<path d="{d}" fill="none" stroke="{c}" stroke-width="{s.width}" '
                    f'stroke-opacity="{s.opacity}" stroke-linejoin="round"/>')
        if s.kind == 'bars':
            top, bottom = fy(s.ys[0] + s.size / 2), fy(s.ys[0] - s.size / 2)
            rects = ''.join(f'M{fx(a):.1f} {top:.1f}H{max(fx(a + w), fx(a) + 1):.1f}V{bottom:.1f}'
                            f'H{fx(a):.1f}Z' for a, w in s.bars)
            return f'<path d="{rects}" fill="{c}" fill-opacity="{s.opacity}"/>'
        if s.kind == 'columns':
            base = fy(y0)
            rects = ''.join(f'M{fx(s.xs[i]):.1f} {base:.1f}V{fy(n):.1f}H{fx(s.xs[i + 1]):.1f}V{base:.1f}Z'
                            for i, n in enumerate(s.ys) if n > 0)
            return f'<path d="{rects}" fill="{c}"/>'
        if s.kind == 'vlines':
            lines = ''.join(f'M{fx(x):.1f} 0V2000' for x in s.xs)
            return f'<path d="{lines}" stroke="{c}" stroke-width="{s.width}" fill="none"/>'
        return _markers(s, [(fx(x), fy(y)) for x, y in zip(s.xs, s.ys)], c)

    def _legend(self, right: float, top: float) -> str:
        entries = [s for s in self.series if s.label]
        if not entries:
            return ''
        width = 34 + CHAR_W * max(len(s.label or '') for s in entries)
        x = right - width - 6
        out = [f'<rect x="{x:.1f}" y="{top + 6}" width="{width:.1f}" height="{len(entries) * 16 + 6}" '
               'fill="#fff" fill-opacity="0.85" stroke="#ccc"/>']
        for i, s in enumerate(entries):
            y = top + 18 + 16 * i
            c = color(s.color)
            if s.kind == 'markers':
                out.append(_markers(s, [(x + 14, y - 4)], c))
            elif s.kind in ('bars', 'fill', 'columns'):
                out.append(f'<rect x="{x + 6:.1f}" y="{y - 9}" width="16" height="9" fill="{c}" '
                           f'fill-opacity="{0.5 if s.kind != "columns" else 1}"/>')
            else:
                out.append(f'<path d="M{x + 6:.1f} {y - 4}h16" stroke="{c}" stroke-width="{max(s.width, 1.5)}"/>')
            out.append(f'<text x="{x + 28:.1f}" y="{y}">{escape(s.label or "")}</text>')
        return ''.join(out)


def _markers(s: _Series, points: Sequence[tuple[float, float]], c: str) -> str:
    r = s.size / 2
    if s.marker == '^':
        d = ''.join(f'M{x:.1f} {y - r:.1f}l{r:.1f} {2 * r:.1f}h{-2 * r:.1f}Z' for x, y in points)
        return f'<path d="{d}" fill="{c}"/>'
    if s.marker == '|':
        d = ''.join(f'M{x:.1f} {y - r:.1f}v{2 * r:.1f}' for x, y in points)
        return f'<path d="{d}" stroke="{c}" stroke-width="1.2" fill="none"/>'
    if s.marker == 'x':
        d = ''.join(f'M{x - r:.1f} {y - r:.1f}l{2 * r:.1f} {2 * r:.1f}m0 {-2 * r:.1f}l{-2 * r:.1f} {2 * r:.1f}'
                    for x, y in points)
        return f'<path d="{d}" stroke="{c}" stroke-width="2" fill="none"/>'
    return ''.join(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r / 2:.1f}" fill="{c}"/>' for x, y in points)
