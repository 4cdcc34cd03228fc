"""The report's plots (inline SVG drawn by svgchart, no matplotlib): each plot is well-formed
SVG with its title, axis labels and legend, refers to nothing outside the page, and keeps a
long series' peaks when it draws fewer points than the series has."""
from __future__ import annotations

import re
import struct
import xml.etree.ElementTree as ET
from pathlib import Path

from drive_bridge.bag.diagnose import diagnose, load_inputs, plots
from drive_bridge.bag.diagnose.report_html import render
from drive_bridge.bag.diagnose.report_json import to_json
from drive_bridge.bag.diagnose.svgchart import Chart, nice_ticks
from drive_bridge.bag.source import open_recording

NODES = (2, 3)


def pdo_bus_log(path: Path) -> Path:
    """Two CiA 402 drives: boot-up, TPDO1/RPDO1 mapped by SDO (statusword + position actual,
    controlword + target), NMT start, then 1.5 s of SYNC, RPDO1, TPDO1 at 1 kHz and heartbeats."""
    lines: list[str] = []
    t = 1_700_000_000.0

    def add(cob: int, data: bytes, at: float | None = None) -> None:
        nonlocal t
        t = at if at is not None else t + 0.00002
        lines.append(f'({t:.6f}) can0 {cob:03X}#{data.hex().upper()}\n')

    for node in NODES:
        add(0x700 + node, b'\0')
        for index, entries in ((0x1A00, (0x60410010, 0x60640020)), (0x1600, (0x60400010, 0x607A0020))):
            for sub, value in [(0, 0)] + list(enumerate(entries, 1)) + [(0, len(entries))]:
                add(0x600 + node, struct.pack('<BHBI', 0x23, index, sub, value))
                add(0x580 + node, struct.pack('<BHBI', 0x60, index, sub, 0))
    add(0x000, b'\x01\x00')
    for cycle in range(1, 1500):
        add(0x080, b'', 1_700_000_001.0 + cycle * 0.001)
        for node in NODES:
            add(0x200 + node, struct.pack('<Hi', 0x0F, cycle * 10))
            add(0x180 + node, struct.pack('<Hi', 0x1237, cycle * 10 - 3 - cycle % 7))
            if cycle % 100 == node:
                add(0x700 + node, b'\x05')
    path.write_text(''.join(lines))
    return path


def svgs(html: str) -> list[ET.Element]:
    return [ET.fromstring(text) for text in re.findall(r'<svg.*?</svg>', html, re.S)]


def test_every_plot_of_a_drive_bus_is_well_formed_svg(tmp_path: Path) -> None:
    path = pdo_bus_log(tmp_path / 'bus.log')
    recording = open_recording(path)
    d = diagnose(recording, load_inputs(recording))
    html = render(d, to_json(d))
    charts = svgs(html)
    titles = [c.get('aria-label') for c in charts]
    assert titles == ['Nodes: alive by heartbeat (green) / guarding (cyan); grey lines: NMT commands to all',
                      'CiA 402 state per axis', 'SYNC period histogram', 'Bus load (100 ms bins)', 'Following error']
    for chart in charts:
        assert chart.tag == 'svg' and not any('xmlns' in k for k in chart.attrib)
        texts = [t.text for t in chart.iter('text')]
        assert chart.get('aria-label') in texts  # the title
        assert 'time [s]' in texts or 'SYNC period [ms]' in texts  # the x axis' label
    legend = [t.text for t in charts[1].iter('text')]
    assert 'node 2 axis 1' in legend and 'operation enabled' in legend
    assert 'http' not in html and '<script' not in html


def test_ticks_are_round_and_cover_the_range() -> None:
    assert nice_ticks(0.0, 997.6, 10) == [0.0, 100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0, 900.0]
    assert nice_ticks(-0.3, 2.7, 5) == [0.0, 1.0, 2.0]
    assert nice_ticks(5.0, 5.0) == [5.0]


def test_a_long_series_keeps_its_extremes() -> None:
    times = [i * 0.001 for i in range(100_000)]
    errors = [0.0] * 100_000
    errors[54_321] = 40.0  # one spike a stride would skip
    errors[77_777] = -12.0
    xs, ys = plots._envelope(times, errors)
    assert len(xs) <= 2 * plots.MAX_POINTS and max(ys) == 40.0 and min(ys) == -12.0
    chart = Chart('Following error', 'time [s]')
    chart.line(xs, ys, 'C0', 'axis')
    ET.fromstring(chart.render())
