"""`drive-bridge diagnose` on every real trace in ../shared/realdata/traces: it runs without
error, and its JSON and HTML report name the nodes, NMT and boot events, SDO transactions,
guarding and EMCY events that are in the trace.

The expected counts below were taken once by an independent reading of each trace (the
`inspect` function here: plain loops over python-can's reader, no diagnosis code) and agree
with ../shared/realdata/SOURCES.md where it gives them (pcan2: 187 guarding RTRs on 0x70A;
pcan3: one EMCY 0x8130 from node 15 and three NMT frames with command byte 0x00; ixxat1: 40
guarding RTRs, 37 on 0x709 and 3 on 0x702). `test_expected_counts_are_the_traces` re-derives
them, so the table cannot drift from the files.
"""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
from typing import Any

import can
import pytest

from configtools import REALDATA
from diagnosetools import check_self_contained
from drive_bridge.cli.main import main

TRACES = REALDATA / 'traces'

# nodes: ids that sent frames; sdo: initiated transactions; aborts: client + server aborts;
# guard: guarding RTRs per node; emcy: (node, code) of every EMCY frame
EXPECTED: dict[str, dict[str, Any]] = {
    'pcan1.trc': dict(nodes=[1, 15, 40, 90], nmt=348, invalid=0, boot_ups={15: 16, 90: 4, 40: 1},
                      sdo=3196, aborts=89, guard={}, emcy=[]),
    'pcan2.trc': dict(nodes=[1, 10, 15, 30], nmt=378, invalid=0, boot_ups={15: 1},
                      sdo=282, aborts=3, guard={10: 187}, emcy=[]),
    'pcan3.trc': dict(nodes=[1, 10, 15, 40, 41, 42, 45, 85, 99, 112, 115], nmt=1580, invalid=4,
                      boot_ups={85: 4}, sdo=5187, aborts=61, guard={10: 830, 42: 829}, emcy=[(15, 0x8130)]),
    'ixxat1.trc': dict(nodes=[1, 3, 9], nmt=158, invalid=0, boot_ups={3: 1}, sdo=56, aborts=9,
                       guard={2: 3, 9: 37}, emcy=[(3, 0x0000)] * 5 + [(3, 0x8120), (9, 0x0000)]),
    'ros2_canopen_issue331_cia402_velocity_enable_excerpt.log': dict(
        nodes=[1, 2, 3, 4, 52], nmt=2, invalid=0, boot_ups={1: 2, 2: 1, 3: 1, 4: 1, 52: 1}, sdo=10, aborts=0,
        guard={}, emcy=[]),
}
for _expected in EXPECTED.values():
    _expected['emcy'].sort()
EXPECTED['ixxat1.converted.log'] = EXPECTED['ixxat1.trc']


def inspect(path: Path) -> dict[str, Any]:
    """Counts by plain loops over the frames (the independent reading the table comes from)."""
    out: dict[str, Any] = dict(nodes=set(), nmt=0, invalid=0, boot_ups={}, sdo=0, aborts=0, guard={}, emcy=[])
    for m in can.LogReader(str(path)):
        cob, data, node = m.arbitration_id, bytes(m.data), m.arbitration_id & 0x7F
        sends = 0x80 < cob < 0x100 or cob >> 7 in (3, 5, 7, 9) or 0x580 < cob < 0x600 or 0x700 < cob < 0x780
        if sends and node and not m.is_remote_frame:
            out['nodes'].add(node)
        if cob == 0:
            out['nmt'] += 1
            out['invalid'] += len(data) != 2 or data[0] not in (1, 2, 0x80, 0x81, 0x82)
        elif 0x80 < cob < 0x100:
            out['emcy'].append((node, int.from_bytes(data[:2].ljust(2, b'\0'), 'little')))
        elif 0x600 < cob < 0x680 and data:
            out['sdo'] += data[0] >> 5 in (1, 2, 5, 6)
            out['aborts'] += data[0] >> 5 == 4
        elif 0x580 < cob < 0x600 and data:
            out['aborts'] += data[0] >> 5 == 4
        elif 0x700 < cob < 0x780 and m.is_remote_frame:
            out['guard'][node] = out['guard'].get(node, 0) + 1
        elif 0x700 < cob < 0x780 and data == b'\0':
            out['boot_ups'][node] = out['boot_ups'].get(node, 0) + 1
    out['nodes'] = sorted(out['nodes'])
    out['emcy'].sort()
    return out


def rounded(value: Any) -> Any:
    """Floats to 4 decimals, in nested JSON data."""
    if isinstance(value, float):
        return round(value, 4)
    if isinstance(value, dict):
        return {k: rounded(v) for k, v in value.items()}
    if isinstance(value, list):
        return [rounded(v) for v in value]
    return value


@pytest.mark.parametrize('name', sorted(n for n in EXPECTED if not n.endswith('ixxat1.trc')))
def test_expected_counts_are_the_traces(name: str) -> None:
    found = inspect(TRACES / name)
    expected = dict(EXPECTED[name])
    assert found == expected


def test_every_trace_is_covered() -> None:
    assert sorted(p.name for p in TRACES.iterdir() if p.is_file()) == sorted(EXPECTED)


@pytest.fixture(scope='module')
def reports(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[dict[str, Any], str, str]]:
    """(JSON, HTML, stdout) of `drive-bridge diagnose` for every trace."""
    out = {}
    tmp = tmp_path_factory.mktemp('diagnose')
    for name in EXPECTED:
        html, js = tmp / f'{name}.html', tmp / f'{name}.json'
        stdout = io.StringIO()
        with contextlib.redirect_stdout(stdout):
            rc = main(['diagnose', str(TRACES / name), '-o', str(html), '--json', str(js), '--no-progress'])
        assert rc == 0, name
        out[name] = (json.loads(js.read_text()), html.read_text(encoding='utf-8'), stdout.getvalue())
    return out


@pytest.mark.parametrize('name', sorted(EXPECTED))
def test_report_names_what_is_in_the_trace(name: str, reports: dict[str, tuple[dict[str, Any], str, str]]) -> None:
    data, html, stdout = reports[name]
    want = EXPECTED[name]
    nodes = [n['node'] for n in data['nodes']]
    assert nodes == want['nodes']
    assert data['nmt']['commands'] == want['nmt']
    assert data['nmt']['invalid_commands'] == want['invalid']
    assert {n['node']: n['boot_ups'] for n in data['nodes'] if n['boot_ups']} == want['boot_ups']
    assert len(data['sdo']['transactions']) == want['sdo']
    assert sum(1 for t in data['sdo']['transactions'] if t['status'] == 'abort') == want['aborts']
    guard = {}
    for node in data['nodes'] + [{'node': n} for n in data['nodes_addressed_only']]:
        requests = node.get('guarding', {}).get('requests')
        if requests:
            guard[node['node']] = requests
    if name.startswith('ixxat1'):  # node 2 is guarded but never answers: listed as addressed only
        assert data['nodes_addressed_only'] == [2]
        guard[2] = 3
    assert guard == want['guard']
    assert sorted((e['node'], int(e['code'], 16)) for e in data['emcy']) == sorted(want['emcy'])
    # the HTML says the same, and stands alone
    parser = check_self_contained(html, plots=2 if data['recording']['duration_s'] >= 1 else 0)
    text = ' '.join(parser.text)
    for node in want['nodes']:
        assert f'node {node}' in text
    assert f'{want["nmt"]} NMT commands' in text and f'{len(data["sdo"]["transactions"])} transactions' in text
    for _node, code in want['emcy']:
        assert f'EMCY 0x{code:04X}' in text
    nodes_line = next(line for line in stdout.splitlines() if line.startswith('nodes: '))
    assert [int(n.split()[0]) for n in nodes_line[len('nodes: '):].split(', ')] == want['nodes']
    assert 'findings: ' in stdout


def test_pcan3_findings(reports: dict[str, tuple[dict[str, Any], str, str]]) -> None:
    data = reports['pcan3.trc'][0]
    findings = data['findings']
    emcy = [f for f in findings if f['kind'] == 'emcy']
    assert [(f['node'], f['severity']) for f in emcy] == [(15, 'error')]
    assert '0x8130' in emcy[0]['what'] and 'life guard' in emcy[0]['what']
    assert abs(emcy[0]['time'] - data['emcy'][0]['time']) < 1e-6
    assert sum(f['kind'] == 'nmt-invalid' for f in findings) == 4
    # node 85 boots twice on its own (the master answers each with a reset node 1 ms later)
    restarts = [f for f in findings if f['kind'] == 'unexpected-restart']
    assert [(f['node'], round(f['time'], 1)) for f in restarts] == [(85, 350.7), (85, 402.5)]
    assert [f['outcome'] for f in restarts] == ['recovered: operational again at t=357.877 s',
                                                'recovered: operational again at t=409.727 s']
    assert emcy[0]['outcome'] == 'unresolved at the end of the recording'  # no error-reset EMCY follows
    assert data['nmt']['commanded_boot_ups'] == 2


def test_pcan2_a_late_boot_after_a_reset_is_no_unexpected_restart(
        reports: dict[str, tuple[dict[str, Any], str, str]]) -> None:
    """Node 15 is reset at 113.8 s and 138.1 s, silent, and boots at 197.6 s: the answer to
    the reset (late), not a restart of its own (canopen-lens counts it as one)."""
    data = reports['pcan2.trc'][0]
    assert data['nmt']['unexpected_restarts'] == 0
    late = [f for f in data['findings'] if f['kind'] == 'late-boot']
    assert [(f['node'], round(f['time'], 1)) for f in late] == [(15, 197.6)]
    assert not [f for f in data['findings'] if f['kind'] == 'heartbeat-gap' and f['node'] == 15]


def test_identity_from_sdo(reports: dict[str, tuple[dict[str, Any], str, str]]) -> None:
    ids = {n['node']: n['identity'] for n in reports['pcan1.trc'][0]['nodes']}
    assert ids[40]['device name'] == 'G66SX-8UVL-2UVFHDM-CANopen'
    assert ids[90]['device name'] == 'Digital InkSupply'
    assert ids[15]['device name'].strip() == 'beta.tz'
    ixxat = {n['node']: n['identity'] for n in reports['ixxat1.trc'][0]['nodes']}
    assert ixxat[3]['device type'] == '0x0000012D' and ixxat[3]['device name'] == 'AddOn IO'
    elmo = {n['node']: n['identity'] for n in reports[
        'ros2_canopen_issue331_cia402_velocity_enable_excerpt.log'][0]['nodes']}[3]
    assert elmo['profile'] == 'CiA 402 drive' and elmo['vendor'] == 'Elmo Motion Control'


def test_cia402_from_the_predefined_tpdo1(reports: dict[str, tuple[dict[str, Any], str, str]]) -> None:
    """The issue-331 excerpt: device type 0x00020192 read by SDO, then TPDO1 0x183 = 0x0237."""
    data = reports['ros2_canopen_issue331_cia402_velocity_enable_excerpt.log'][0]
    axes = data['cia402']
    assert [(a['node'], a['state']) for a in axes] == [(3, 'operation enabled')]
    assert [m['mode'] for m in axes[0]['modes']] == ['pv']  # 0x6061 read back = 3, as written
    pdo = {row['cob_id']: row for row in data['pdo']}['0x183']
    assert pdo['mapping_source'] == 'CiA 402 predefined'
    assert pdo['last_values'] == {'0x6041:0 Statusword': 0x0237}
    writes = [t for t in data['sdo']['transactions'] if t['access'] == 'write' and t['object'].startswith('0x6040')]
    assert [(t['value'], t['status']) for t in writes] == [
        ('0x0006 (6)', 'ok'), ('0x0007 (7)', 'ok'), ('0x000F (15)', 'ok'), ('0x7364 (29540)', 'open')]  # cut off


def test_guarding_toggle_and_replies(reports: dict[str, tuple[dict[str, Any], str, str]]) -> None:
    nodes = {n['node']: n for n in reports['pcan2.trc'][0]['nodes']}
    guarding = nodes[10]['guarding']
    assert guarding['requests'] == 187 and guarding['replies'] + guarding['unanswered'] <= 187
    assert guarding['period_s'] is not None and 0.1 < guarding['period_s'] < 5


@pytest.mark.parametrize('name', ['ixxat1.trc', 'pcan2.trc'])
def test_an_imported_trace_diagnoses_the_same(name: str, tmp_path: Path,
                                              reports: dict[str, tuple[dict[str, Any], str, str]]) -> None:
    """`drive-bridge import` to a bag, then diagnose the bag: the same nodes, events and findings."""
    bag = tmp_path / 'bag'
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(['import', str(TRACES / name), '-o', str(bag), '-q']) == 0
        assert main(['diagnose', str(bag), '-o', str(tmp_path / 'r.html'), '--json', str(tmp_path / 'r.json'),
                     '--no-progress']) == 0
    data = json.loads((tmp_path / 'r.json').read_text())
    trace = reports[name][0]
    assert data['recording']['format'] == 'rosbag2-mcap'
    for key in ('nodes', 'nmt', 'emcy', 'cia402', 'pdo'):  # bag stamps are ns: times to 0.1 ms
        assert rounded(data[key]) == rounded(trace[key]), key
    assert rounded(data['sdo']['transactions']) == rounded(trace['sdo']['transactions'])
    assert [(f['kind'], f['node'], f['what']) for f in data['findings']] == \
        [(f['kind'], f['node'], f['what']) for f in trace['findings']]
