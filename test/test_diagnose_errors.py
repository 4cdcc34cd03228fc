"""Bad inputs to `drive-bridge diagnose` give one clear line naming what was wrong (exit 2)."""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import can
import pytest

from configtools import REALDATA
from drive_bridge.cli.main import main

TRACE = REALDATA / 'traces' / 'ros2_canopen_issue331_cia402_velocity_enable_excerpt.log'
DEMO = Path(__file__).resolve().parents[1] / 'config' / 'demo.yaml'


def error_of(*args: str) -> str:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(['diagnose', *args, '--no-progress'])
    assert rc == 2
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('drive-bridge diagnose: error: '), lines
    return lines[0]


def test_missing_file(tmp_path: Path) -> None:
    assert 'nope.trc: no such file' in error_of(str(tmp_path / 'nope.trc'), '-o', str(tmp_path / 'r.html'))


def test_unknown_format(tmp_path: Path) -> None:
    path = tmp_path / 'frames.xyz'
    path.write_text('hello\n')
    assert "frames.xyz: unknown format '.xyz'" in error_of(str(path), '-o', str(tmp_path / 'r.html'))


def test_corrupt_trace(tmp_path: Path) -> None:
    path = tmp_path / 'broken.trc'
    path.write_text(';$FILEVERSION=2.1\n;$COLUMNS=N,O,T,B,I,d,R,L,D\n      1  zz DT 1 0770 Rx - 1 05\n')
    message = error_of(str(path), '-o', str(tmp_path / 'r.html'))
    assert 'broken.trc' in message


def test_empty_trace(tmp_path: Path) -> None:
    path = tmp_path / 'empty.log'
    path.write_text('')
    assert 'empty.log: the recording holds no CAN frames' in error_of(str(path), '-o', str(tmp_path / 'r.html'))


def test_config_that_does_not_match_the_trace(tmp_path: Path) -> None:
    pcan2 = REALDATA / 'traces' / 'pcan2.trc'
    message = error_of(str(pcan2), '--config', str(DEMO), '-o', str(tmp_path / 'r.html'))
    assert 'does not match the trace' in message and 'node(s) 2, 3, 4' in message
    assert 'node(s) 1, 10, 15, 30' in message


def test_config_that_matches_part_of_the_trace(tmp_path: Path) -> None:
    """The demo config names nodes 2, 3 and 4 of the excerpt; nodes 1 and 52 are on the bus but
    not in the config: a finding each (the diagnosis goes on)."""
    js = tmp_path / 'r.json'
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(TRACE), '--config', str(DEMO), '-o', str(tmp_path / 'r.html'),
                     '--json', str(js), '--no-progress']) == 0
    findings = json.loads(js.read_text())['findings']
    extra = sorted(f['node'] for f in findings if f['kind'] == 'config-node-extra')
    assert extra == [1, 52]
    assert not [f for f in findings if f['kind'] == 'config-node-missing']


def test_missing_and_bad_config(tmp_path: Path) -> None:
    assert 'absent.yaml: no such config file' in error_of(str(TRACE), '--config', str(tmp_path / 'absent.yaml'))
    bad = tmp_path / 'bad.yaml'
    bad.write_text('nodes: [1, 2\n')
    assert 'bad.yaml' in error_of(str(TRACE), '--config', str(bad), '-o', str(tmp_path / 'r.html'))


@pytest.mark.parametrize('arg, text', [('3', 'expected NODE=FILE'), ('300=x.eds', 'node id 1..127'),
                                       ('3=/nonexistent/drive.eds', 'drive.eds: no such file')])
def test_bad_eds_argument(arg: str, text: str) -> None:
    assert text in error_of(str(TRACE), '--eds', arg)


def test_eds_names_objects(tmp_path: Path) -> None:
    """With the drive's EDS the objects carry its names, and its vendor is known."""
    js = tmp_path / 'r.json'
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(TRACE), '--eds', f'3={REALDATA / "eds" / "Elmo.dcf"}', '-o',
                     str(tmp_path / 'r.html'), '--json', str(js), '--no-progress']) == 0
    data = json.loads(js.read_text())
    objects = {t['object'] for t in data['sdo']['transactions']}
    assert any(o.startswith('0x60FF:0 ') for o in objects)
    node3 = next(n for n in data['nodes'] if n['node'] == 3)
    assert node3['identity']['vendor'] == 'Elmo Motion Control'
    # TPDO1 as the DCF maps it (statusword, mode display, a timestamp: 7 bytes); the drive sends 2
    tpdo1 = {row['cob_id']: row for row in data['pdo']}['0x183']
    assert tpdo1['mapping_source'] == 'EDS default' and len(tpdo1['mapping']) == 3
    assert tpdo1['last_values'] == {'0x6041:0 statusword': 0x0237}
    [length] = [f for f in data['findings'] if f['kind'] == 'pdo-length']
    assert length['what'] == 'TPDO1 of node 3 (0x183) carries 2 bytes, its mapping (EDS default) 7'


def test_unwritable_report(tmp_path: Path) -> None:
    assert 'cannot write' in error_of(str(TRACE), '-o', str(tmp_path / 'no' / 'such' / 'dir' / 'r.html'))


def test_error_frames_are_a_finding(tmp_path: Path) -> None:
    """Bus-error frames as candump logs them (python-can's reader knows class 0x80 only)."""
    path = tmp_path / 'errors.log'
    path.write_text('(1.000000) can0 705#05\n(1.500000) can0 20000080#0000000000000000\n'
                    '(1.600000) can0 20000080#0000000000000000\n(2.000000) can0 705#05\n')
    js = tmp_path / 'r.json'
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(path), '-o', str(tmp_path / 'r.html'), '--json', str(js), '--no-progress']) == 0
    data = json.loads(js.read_text())
    assert data['recording']['error_frames'] == 2 and data['recording']['extended_frames'] == 0
    [finding] = [f for f in data['findings'] if f['kind'] == 'bus-errors']
    assert finding['what'] == '2 CAN error frame(s): bus error' and finding['time'] == 0.5


@pytest.mark.parametrize('key', ['/ABS/evil.eds', '../../../../../../../../ABS/evil.eds', 'a/../../evil.eds'])
def test_a_stored_file_key_never_writes_outside_the_temporary_directory(tmp_path: Path, key: str) -> None:
    """A bag names its stored files; diagnose (and decode) write them only inside their temp dir."""
    from drive_bridge.bag.recorder import Recorder
    outside = tmp_path / 'outside'
    outside.mkdir()
    key = key.replace('/ABS', str(outside))
    bag = tmp_path / 'bag'
    config = 'bus: {interface: virtual, channel: x}\nnodes:\n  io: {node_id: 5, family: generic_301}\n'
    recorder = Recorder(bag, config_yaml=config, files={key: b'[FileInfo]\n'})
    recorder.on_frame(can.Message(arbitration_id=0x705, data=b'\x05', timestamp=1.0))
    recorder.stop()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        main(['diagnose', str(bag), '-o', str(tmp_path / 'r.html'), '--no-progress'])
        main(['replay', str(bag), '--decode', '-o', str(tmp_path / 'decoded')])
    assert not list(outside.iterdir()) and not (tmp_path / 'evil.eds').exists()
    assert not list(tmp_path.parent.glob('evil.eds'))


def test_times_going_backwards_and_ids_above_0x7ff_are_findings_not_crashes(tmp_path: Path) -> None:
    path = tmp_path / 'odd.log'
    path.write_text('(10.000000) can0 705#05\n(10.500000) can0 185#0102\n(9.000000) can0 705#05\n'
                    '(9.200000) can0 705#05\n(11.000000) can0 705#05\n(11.100000) can0 9AB#01\n'
                    '(11.200000) can0 800#\n(12.000000) can0 705#05\n')
    js = tmp_path / 'r.json'
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(path), '-o', str(tmp_path / 'r.html'), '--json', str(js), '--no-progress']) == 0
    data = json.loads(js.read_text())
    kinds = [f['kind'] for f in data['findings']]
    assert kinds.count('clock-backwards') == 1 and kinds.count('invalid-id') == 1
    [back] = [f for f in data['findings'] if f['kind'] == 'clock-backwards']
    [invalid] = [f for f in data['findings'] if f['kind'] == 'invalid-id']
    assert back['what'] == 'clock went back 1 times' and invalid['what'].startswith('2 frame(s)')
    assert data['recording']['duration_s'] == pytest.approx(2.0)


def test_a_cia301_node_whose_emcy_is_reset_is_not_said_to_stay_disabled(tmp_path: Path) -> None:
    path = tmp_path / 'io.log'  # an I/O module (no CiA 402 axis): an error EMCY, then the error reset
    path.write_text('(1.000000) can0 705#05\n(1.200000) can0 085#0081100000000000\n'
                    '(2.000000) can0 085#0000000000000000\n(3.000000) can0 705#05\n')
    js = tmp_path / 'r.json'
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(path), '-o', str(tmp_path / 'r.html'), '--json', str(js), '--no-progress']) == 0
    [emcy] = [f for f in json.loads(js.read_text())['findings'] if f['kind'] == 'emcy']
    assert emcy['outcome'] == 'fault cleared at t=1.000 s'
