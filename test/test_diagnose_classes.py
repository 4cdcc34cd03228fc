"""One test per class of diagnosis issue 21 names, each on a small log written here (candump -L
unless the class is about another format): SDO, CiA 402 over PDO without a config, boot, time
base, causes, input formats, the report."""
from __future__ import annotations

import contextlib
import io
import json
import struct
from pathlib import Path
from typing import Any

import pytest

from drive_bridge.cli.main import main


def log(frames: list[tuple[float, int, str]], t0: float = 1_700_000_000.0) -> str:
    """candump -L lines of (time, COB-ID, payload hex)."""
    return ''.join(f'({t0 + t:.6f}) can0 {cob:03X}#{data}\n' for t, cob, data in frames)


def diagnose(tmp: Path, text: str, name: str = 'trace.log', *args: str) -> tuple[dict[str, Any], str, str]:
    """(JSON, stdout, HTML) of `drive-bridge diagnose` on ``text`` saved as ``name``."""
    path = tmp / name
    path.write_text(text)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(['diagnose', str(path), '-o', str(tmp / 'r.html'), '--json', str(tmp / 'r.json'),
                     '--no-progress', *args]) == 0
    return json.loads((tmp / 'r.json').read_text()), out.getvalue(), (tmp / 'r.html').read_text()


def of(data: dict[str, Any], kind: str) -> list[dict[str, Any]]:
    return [f for f in data['findings'] if f['kind'] == kind]


# -- SDO ------------------------------------------------------------------------------------------
def test_sdo_a_burst_of_invalid_server_frames_and_the_abort_inside_it(tmp_path: Path) -> None:
    """A segmented download to 0x7000:1; the server answers the first segment, then floods its
    response COB-ID with frames that answer nothing; the master aborts (timeout), the server's
    own abort comes after: all three are reported, the master's abort with the garbage as cause."""
    frames = [(0.000, 0x603, '2100700140000000'), (0.001, 0x583, '6000700100000000'),
              (0.002, 0x603, '000080000000C0C0'), (0.003, 0x583, '2000000000000000')]
    frames += [(0.004 + i * 0.0002, 0x583, '0000002000000000') for i in range(6)]
    frames += [(0.500, 0x603, '8000000000000405'), (0.501, 0x583, '8000700101000405')]
    data, _, _ = diagnose(tmp_path, log(frames))
    [burst] = of(data, 'sdo-invalid')
    assert burst['node'] == 3 and burst['severity'] == 'error' and '6 invalid frame(s) on 0x583' in burst['what']
    aborts = {f['what'].split(' 0x')[-1][:8]: f for f in of(data, 'sdo-abort')}
    assert 'the master aborted 0x05040000' in aborts['05040000']['what']
    assert '6 invalid frame(s)' in aborts['05040000']['cause']  # it answered, with garbage
    assert 'after the master had given up' in aborts['05040001']['what']
    assert all('axis' not in f['what'] for f in data['findings'])  # 0x7000 is no CiA 402 "axis 3" object
    assert 'SDO server of node 3 sent invalid frames' in data['verdict']


def test_sdo_object_names_outside_cia402_are_not_axis_names(tmp_path: Path) -> None:
    frames = [(0.0, 0x605, '4000700100000000'), (0.001, 0x585, '8000700100000206'),
              (0.1, 0x605, '4040680000000000'), (0.101, 0x585, '8040680000000206')]
    data, _, _ = diagnose(tmp_path, log(frames))
    objects = [t['object'] for t in data['sdo']['transactions']]
    assert objects == ['0x7000:1', '0x6840:0 Controlword (axis 2)']


def test_sdo_a_mandatory_read_aborted_at_boot_is_an_error_not_probing(tmp_path: Path) -> None:
    """0x6502 (supported drive modes, mandatory in CiA 402) aborted 'object does not exist',
    read three times: an error the summary prints, grouped as one line x3."""
    frames = [(0.0, 0x000, '8200'), (0.01, 0x702, '00')]
    for i in range(3):
        frames += [(0.1 + i * 0.1, 0x602, '4002650000000000'), (0.101 + i * 0.1, 0x582, '8002650000000206')]
    frames += [(0.5, 0x602, '4000200100000000'), (0.501, 0x582, '8000200100000206')]  # a vendor object: probing
    data, stdout, _ = diagnose(tmp_path, log(frames))
    severities = {f['what'].split()[1]: f['severity'] for f in of(data, 'sdo-abort')}
    assert severities == {'0x6502': 'error', '0x2000:1': 'info'}
    [group] = [g for g in data['grouped'] if g['kind'] == 'sdo-abort' and g['severity'] == 'error']
    assert group['count'] == 3 and 'mandatory (CiA 402)' in group['cause']
    assert data['verdict'].startswith('3 errors: node 2 lacks mandatory 0x6502 (Supported drive modes) (×3)')
    assert '×3' in stdout


# -- CiA 402 over PDO, no config ------------------------------------------------------------------
def test_cia402_over_pdo_inferred_from_the_traffic(tmp_path: Path) -> None:
    """No SDO, no config: RPDO1 takes only controlword commands, TPDO1 only statuswords, so the
    enable, the Fault (with the EMCY that follows it) and the recovery are seen."""
    words = [(0x06, 0x0231), (0x07, 0x0233), (0x0F, 0x0237), (0x0F, 0x0238), (0x80, 0x0250),
             (0x06, 0x0231), (0x07, 0x0233), (0x0F, 0x0237)]
    frames: list[tuple[float, int, str]] = []
    for i, (cw, sw) in enumerate(words):
        t = 0.1 + i * 0.1
        frames += [(t, 0x080, ''), (t + 0.001, 0x201, struct.pack('<H', cw).hex()),
                   (t + 0.002, 0x181, struct.pack('<H', sw).hex())]
        if sw == 0x0238:
            frames.append((t + 0.0021, 0x081, '1023020000000000'))  # the EMCY 0.1 ms after the Fault row
    data, _, _ = diagnose(tmp_path, log(frames))
    [axis] = data['cia402']
    assert [(s['from'], s['to']) for s in axis['transitions']][:4] == [
        ('unknown', 'ready to switch on'), ('ready to switch on', 'switched on'),
        ('switched on', 'operation enabled'), ('operation enabled', 'fault')]
    assert axis['state'] == 'operation enabled'
    [fault] = of(data, 'cia402-fault')
    assert 'EMCY 0x2310' in fault['cause'] and 'after the statusword' in fault['cause']  # not "no EMCY seen"
    assert fault['outcome'].startswith('recovered: operation enabled again')
    pdo = {row['cob_id']: row['mapping_source'] for row in data['pdo']}
    assert pdo == {'0x181': 'inferred from the traffic', '0x201': 'inferred from the traffic'}


def test_an_io_node_pdo_is_not_taken_for_a_drive(tmp_path: Path) -> None:
    frames = [(i * 0.01, 0x181 if i % 2 else 0x201, 'FF13' if i % 2 else 'A501') for i in range(40)]
    data, _, _ = diagnose(tmp_path, log(frames))
    assert data['cia402'] == []


# -- boot --------------------------------------------------------------------------------------------
def test_a_boot_that_stalls_after_the_identity_read(tmp_path: Path) -> None:
    frames = [(0.0, 0x701, '00'), (0.001, 0x000, '8200'), (0.002, 0x702, '00'), (0.003, 0x703, '00'),
              (0.004, 0x602, '4000100000000000'), (0.005, 0x582, '4300100092010200'),
              (0.006, 0x602, '4018100100000000'), (0.007, 0x582, '4318100100030000')]
    frames += [(0.01 + i * 0.01, 0x080, '') for i in range(30)]
    data, _, _ = diagnose(tmp_path, log(frames))
    [stall] = of(data, 'boot-stall')
    assert stall['severity'] == 'error' and 'no NMT start' in stall['what']
    assert '0x1000, 0x1018:1 of node 2' in stall['what'] and 'node(s) 3 never configured' in stall['what']
    assert data['verdict'].startswith('1 error: boot stalled after the SDO to node 2')


def test_a_node_that_boots_late_is_linked_to_the_sdo_timeouts(tmp_path: Path) -> None:
    frames = [(0.0, 0x000, '8200')]
    for i in range(3):
        frames += [(0.1 + i * 0.5, 0x602, '4000100000000000'), (0.6 + i * 0.5 - 0.001, 0x602, '8000100000000405')]
    frames += [(1.9, 0x702, '00'), (1.95, 0x602, '4000100000000000'), (1.951, 0x582, '4300100092010200'),
               (2.0, 0x000, '0102'), (2.01, 0x702, '05'), (3.01, 0x702, '05')]
    data, _, _ = diagnose(tmp_path, log(frames))
    [late] = of(data, 'late-boot')
    assert late['node'] == 2 and 'booted 1.900 s after the NMT reset communication' in late['what']
    assert '3 SDO request(s) to it had timed out' in late['what']
    timeouts = [f for f in of(data, 'sdo-abort') if '0x05040000' in f['what']]
    assert len(timeouts) == 3 and all(f['cause'].startswith('node 2 had not booted yet') for f in timeouts)


# -- time base ----------------------------------------------------------------------------------------
def test_synthetic_time_stamps_give_no_timing_findings(tmp_path: Path) -> None:
    """A converted log that numbers its frames 1 ms apart: its heartbeats 'stop' and SYNC 'gaps'
    are artefacts; the diagnosis says timing is not judged instead."""
    frames: list[tuple[float, int, str]] = []
    for i in range(300):
        frames.append((0, 0x080, '') if i % 3 else (0, 0x705, '05'))
    frames += [(0, 0x080, '')] * 200
    text = ''.join(f'({i * 0.001:.6f}) can0 {cob:03X}#{data}\n' for i, (_t, cob, data) in enumerate(frames))
    data, _, _ = diagnose(tmp_path, text)
    kinds = {f['kind'] for f in data['findings']}
    assert not kinds & {'heartbeat-stopped', 'heartbeat-gap', 'sync-gap', 'pdo-gap', 'bus-load'}
    assert data['recording']['timebase'] == 'synthetic (every frame 1 ms after the last)'
    assert 'timing not judged' in data['verdict']


def test_screen_output_without_time_stamps(tmp_path: Path) -> None:
    text = '  can0  705   [1]  05\n  can0  080   [0] \n' * 5
    data, _, html = diagnose(tmp_path, text, 'paste.txt')
    assert data['recording']['format'] == 'candump-screen' and data['recording']['timebase'] == 'none'
    assert [f['kind'] for f in data['findings']] == ['timebase']
    assert 'no time stamps' in html


# -- causes -------------------------------------------------------------------------------------------
@pytest.mark.parametrize(('code', 'words'), [('2171', 'motor blocked'), ('2063', 'parameter error')])
def test_emcy_causes_by_code(tmp_path: Path, code: str, words: str) -> None:
    data, _, _ = diagnose(tmp_path, log([(0.0, 0x705, '05'), (0.1, 0x085, f'{code}010000000000')]))
    [emcy] = of(data, 'emcy')
    assert emcy['cause'].startswith(words)
    assert 'additional module' not in emcy['cause'] and 'firmware' not in emcy['cause']


def test_a_notice_emcy_after_the_masters_reset_is_no_fault_cause(tmp_path: Path) -> None:
    frames = [(0.0, 0x000, '8203'), (0.014, 0x703, '00'), (0.017, 0x083, 'B081010000000000'),
              (0.23, 0x603, '4041600000000000'), (0.231, 0x583, '4B41600018020000')]
    data, _, _ = diagnose(tmp_path, log(frames))
    [emcy] = of(data, 'emcy')
    assert emcy['severity'] == 'info' and 'notice of the NMT reset' in emcy['cause']
    [fault] = of(data, 'cia402-fault')
    assert '0x81B0' not in fault['cause'] and 'no EMCY seen' in fault['cause']


def test_repeated_emcys_linked_to_the_pdo_that_triggers_them_and_sent_by_the_master(tmp_path: Path) -> None:
    """The master (node 127: only heartbeats and EMCYs) answers each TPDO1 of node 3 that is
    shorter than its mapping with EMCY 0x8210."""
    frames = [(0.0, 0x77F, '05'), (0.001, 0x000, '0100')]
    for i in range(38):
        t = 0.01 + i * 0.01
        frames += [(t, 0x183, '3706'), (t + 0.0002, 0x0FF, '1082110000000000')]
    frames.append((0.5, 0x77F, '05'))
    data, _, _ = diagnose(tmp_path, log(frames))
    [group] = [g for g in data['grouped'] if g['kind'] == 'emcy']
    assert group['count'] == 38 and group['node'] == 127
    assert '38 of the 38 identical EMCYs each follow a frame of TPDO1 of node 3 (0x183)' in group['cause']
    assert 'node 127 is the master' in group['cause']


def test_can_error_frames_are_bus_errors(tmp_path: Path) -> None:
    text = log([(0.0, 0x705, '05')]) + ''.join(
        f'({1_700_000_000 + 0.1 + i * 0.01:.6f}) can0 20000004#0010000000000000\n' for i in range(3))
    data, _, _ = diagnose(tmp_path, text)
    assert data['recording']['error_frames'] == 3 and data['recording']['extended_frames'] == 0
    [bus] = of(data, 'bus-errors')
    assert bus['severity'] == 'error' and 'RX error passive' in bus['what']


# -- input ----------------------------------------------------------------------------------------------
SCREEN = ('  can0  000   [2]  82 00\n  can0  701   [1]  00\n  can0  601   [8]  40 00 10 00 00 00 00 00\n'
          '  can0  581   [8]  43 00 10 00 92 01 02 00   // device type\n  can0  TX - -  080   [0] \n'
          '  can0  RX - -  181   [2]  37 02\n  can0  715   [8]  remote request\n')


@pytest.mark.parametrize('name', ['paste.txt', 'renamed.trc', 'noext'])
def test_candump_screen_output_is_read_by_content(tmp_path: Path, name: str) -> None:
    data, _, _ = diagnose(tmp_path, SCREEN, name)
    assert data['recording']['format'] == 'candump-screen' and data['recording']['frames'] == 7
    assert data['recording']['remote_frames'] == 1
    assert [(t['object'], t['status']) for t in data['sdo']['transactions']] == [('0x1000:0 Device type', 'ok')]
    assert data['cia402'][0]['state'] == 'operation enabled'  # device type 402, TPDO1 = statusword


def test_format_option_and_unknown_content(tmp_path: Path) -> None:
    path = tmp_path / 'frames.dat'
    path.write_text('(1.000000) can0 705#05\n(2.000000) can0 705#05\n')
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(path), '--format', 'candump', '--no-html', '--json', str(tmp_path / 'a.json'),
                     '--no-progress']) == 0
    assert json.loads((tmp_path / 'a.json').read_text())['recording']['format'] == 'candump'
    bad = tmp_path / 'notes.txt'
    bad.write_text('hello\nthis is no CAN log\n')
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(bad), '--no-html', '--no-progress']) == 2
    assert "notes.txt: unknown format '.txt'" in err.getvalue() and '--format' in err.getvalue()


# -- the report -------------------------------------------------------------------------------------------
def test_report_verdict_errors_first_grouped_clock_and_units(tmp_path: Path) -> None:
    frames = [(i * 0.1, 0x705, '05') for i in range(30)]
    frames += [(0.05 + i * 0.1, 0x085, '0010010000000000') for i in range(20)]  # 20 identical EMCYs
    frames += [(1.0, 0x605, '2B60600008000000'), (1.001, 0x585, '8060600030000906')]  # a write aborted
    frames += [(i * 0.01, 0x080, '') for i in range(300)]
    frames += [(i * 0.01 + 0.0004 + (i % 3) * 0.00005, 0x185, '3702') for i in range(300)]  # TPDO1 after SYNC
    frames.sort()
    data, stdout, html = diagnose(tmp_path, log(frames, t0=1_700_000_000.0), 'trace.log', '--bitrate', '500000')
    lines = stdout.splitlines()
    assert lines[0].startswith('verdict: ')
    ranked = [line.split()[0] for line in lines if line.startswith('  ')]
    assert ranked == sorted(ranked, key=['ERROR', 'WARNING'].index)  # errors first
    assert any(line.rstrip().endswith('×20') for line in lines)  # the 20 EMCYs: one line
    assert '22:13:21.000 (+1.000 s)' in stdout  # the log's own clock (UTC) and the relative time
    assert 'class="verdict' in html and '×20' in html
    assert ' Hz<' in html and ' ms<' in html and '%<' in html  # units in the tables


def test_a_pdo_slower_than_sync_is_a_finding(tmp_path: Path) -> None:
    frames = [(i * 0.01, 0x080, '') for i in range(200)]
    frames += [(i * 0.01 + 0.0005, 0x183, '3702') for i in range(200) if i % 4]  # every 4th SYNC missed
    frames.sort()
    data, _, _ = diagnose(tmp_path, log(frames))
    [rate] = of(data, 'pdo-rate')
    assert rate['severity'] == 'warning' and '25% of the SYNC cycles go without it' in rate['what']


def test_the_stored_eds_is_named(tmp_path: Path) -> None:
    from drive_bridge.bag.importer import import_trace
    eds = Path(__file__).resolve().parents[1] / 'drive_bridge' / 'families' / 'generic402' / 'data' / 'generic402.eds'
    (tmp_path / 'drive.eds').write_bytes(eds.read_bytes())
    (tmp_path / 'bus.yaml').write_text(
        'bus: {interface: virtual, channel: x}\nnodes:\n'
        '  axis: {node_id: 5, family: generic_402, dcf: drive.eds, axes: [{joint: j}]}\n')
    (tmp_path / 't.log').write_text(log([(0.0, 0x705, '05'), (1.0, 0x705, '05')]))
    import_trace(tmp_path / 't.log', tmp_path / 'bag', tmp_path / 'bus.yaml', progress=False)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(['diagnose', str(tmp_path / 'bag'), '-o', str(tmp_path / 'r.html'), '--json',
                     str(tmp_path / 'r.json'), '--no-progress']) == 0
    data = json.loads((tmp_path / 'r.json').read_text())
    assert data['inputs']['eds'] == {'5': 'drive.eds (stored in the bag)'}
    assert 'node 5: drive.eds (stored in the bag)' in (tmp_path / 'r.html').read_text()


# -- speed: imports on use ------------------------------------------------------------------------------
HEAVY = ('matplotlib', 'numpy', 'rosbags', 'can', 'canopen', 'rclpy', 'drive_bridge.bag.diagnose.engine')


def _modules_after(args: list[str]) -> set[str]:
    import subprocess
    import sys
    code = ('import sys, contextlib, io\nfrom drive_bridge.cli.main import main\n'
            'with contextlib.redirect_stdout(io.StringIO()):\n'
            '    try:\n        main(sys.argv[1:])\n    except SystemExit:\n        pass\n'
            'print(" ".join(sorted(sys.modules)))\n')
    out = subprocess.run([sys.executable, '-c', code, *args], capture_output=True, text=True, check=True, timeout=60)
    return set(out.stdout.split())


def test_diagnose_help_imports_nothing_of_the_diagnosis() -> None:
    loaded = _modules_after(['diagnose', '--help'])
    assert not {m for m in HEAVY if m in loaded}


def test_a_short_log_is_diagnosed_without_plots_numpy_or_rosbags(tmp_path: Path) -> None:
    path = tmp_path / 'short.log'
    path.write_text(log([(0.0, 0x000, '8200'), (0.001, 0x702, '00')] + [(0.01 * i, 0x080, '') for i in range(1, 28)]))
    loaded = _modules_after(['diagnose', str(path), '-o', str(tmp_path / 'r.html'), '--no-progress'])
    assert not {m for m in ('matplotlib', 'numpy', 'rosbags', 'canopen', 'rclpy') if m in loaded}
    assert (tmp_path / 'r.html').stat().st_size > 1000


def test_the_cli_knows_every_format_the_reader_does() -> None:
    from drive_bridge.bag.formats import FORMATS
    from drive_bridge.cli.diagnose import FORMAT_NAMES
    assert set(FORMAT_NAMES) == set(FORMATS)


def test_import_reads_a_paste_by_content_and_takes_format(tmp_path: Path) -> None:
    paste = tmp_path / 'paste.txt'
    paste.write_text(SCREEN)
    with contextlib.redirect_stdout(io.StringIO()) as out:
        assert main(['import', str(paste), '-o', str(tmp_path / 'a'), '-q']) == 0
        assert main(['import', str(paste), '-o', str(tmp_path / 'b'), '-q', '--format', 'candump-screen']) == 0
    assert '(candump-screen)' in out.getvalue() and ': 7 frames' in out.getvalue()
