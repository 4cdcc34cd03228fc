"""`drive-bridge diagnose` on a recording of the simulated bus with injected faults: each
fault is a finding at the time it was injected, on the right node (and joint, when the bag
carries its config), with the right text and probable cause; `--check` fails on it."""
from __future__ import annotations

import contextlib
import io
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
import pytest

from bench.diagnose import synthetic
from diagnosetools import CONFIG_YAML, NODE, PERIOD, FaultRecording, check_self_contained, record_faults
from drive_bridge.bag.writer import BagWriter
from drive_bridge.cli.main import main
from timingtools import BUSY_SLACK

# s between the injection (test thread) and the frame that shows it: a heartbeat period, and
# what a busy machine holds the threads (below the 1 s between the injections)
TOLERANCE = 0.5
pytestmark = pytest.mark.slow  # a recording of 8 s of injected faults, then each diagnosis


@pytest.fixture(scope='module')
def recording(tmp_path_factory: pytest.TempPathFactory) -> Iterator[FaultRecording]:
    yield record_faults(tmp_path_factory.mktemp('faults') / 'faults.log')


def run(*args: str) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rc = main(['diagnose', *args, '--no-progress'])
    return rc, out.getvalue()


def report(path: Path, tmp: Path, *extra: str) -> dict[str, Any]:
    rc, _ = run(str(path), '-o', str(tmp / 'r.html'), '--json', str(tmp / 'r.json'), *extra)
    assert rc == 0
    check_self_contained((tmp / 'r.html').read_text(encoding='utf-8'))
    return json.loads((tmp / 'r.json').read_text())


def one(findings: list[dict[str, Any]], kind: str, text: str = '') -> dict[str, Any]:
    hits = [f for f in findings if f['kind'] == kind and text in f['what']]
    assert len(hits) == 1, (kind, text, findings)
    return hits[0]


def at(rec: FaultRecording, fault: str) -> float:
    return rec.times[fault] - rec.t0


def check_faults(data: dict[str, Any], rec: FaultRecording, joint: str | None) -> None:
    findings = data['findings']
    abort = one(findings, 'sdo-abort')
    assert '0x6060' in abort['what'] and '0x06090030' in abort['what'] and 'write' in abort['what']
    assert abort['cause'].startswith('value range')
    assert abs(abort['time'] - at(rec, 'sdo-abort')) < TOLERANCE

    emcy = one(findings, 'emcy', '0x2310')
    assert emcy['severity'] == 'error' and 'over-current' in emcy['what']
    assert abs(emcy['time'] - at(rec, 'emcy')) < TOLERANCE
    fault = one(findings, 'cia402-fault')
    assert 'operation enabled -> fault' in fault['what'] and '0x2310' in fault['cause']

    skipped = one(findings, 'cia402-command')
    assert '0x000F' in skipped['what'] and 'switch on disabled' in skipped['what']
    assert 'skips a step' in skipped['cause']
    assert abs(skipped['time'] - at(rec, 'skipped-step')) < TOLERANCE

    # the two injected gaps (a busy machine may stall the simulated drive's heartbeat thread
    # too: such a gap is found as well, and is no injection's)
    gaps = [f for f in findings if f['kind'] == 'heartbeat-gap']
    lost = min(gaps, key=lambda f: abs(f['time'] - at(rec, 'heartbeat-loss')))
    rebooted, = [f for f in gaps if f['what'].endswith('then boot-up')]
    assert abs(lost['time'] - at(rec, 'heartbeat-loss')) < TOLERANCE
    assert 0.5 < float(lost['what'].split()[2]) < 0.6 + BUSY_SLACK and 'boot-up' not in lost['what']  # 0.6 s silent
    assert abs(rebooted['time'] - at(rec, 'reboot')) < TOLERANCE
    assert rebooted['cause'] == 'the drive rebooted'
    assert 1.1 < float(rebooted['what'].split()[2]) < 1.2 + BUSY_SLACK  # 1.2 s silent, then boot-up

    restart = one(findings, 'unexpected-restart')
    assert abs(restart['time'] - at(rec, 'boot-up')) < TOLERANCE

    # what came after each: the heartbeat came back; the fault was reset, the axis not enabled
    # again (the recording stops the master after the reboot, before NMT start)
    assert lost['outcome'] == 'recovered: heartbeat back'
    assert emcy['outcome'].startswith('fault cleared at t=') and fault['outcome'] == emcy['outcome']
    assert restart['outcome'] == rebooted['outcome'] == 'unresolved: not operational again in the recording'

    for f in (abort, emcy, fault, skipped, lost, rebooted, restart):
        assert f['node'] == NODE and f['joint'] == joint
    errors = {f['kind'] for f in findings if f['severity'] == 'error'}
    assert errors == {'sdo-abort', 'emcy', 'cia402-fault', 'heartbeat-gap', 'unexpected-restart'}
    # the commanded reset communication is no restart; the power-on is none either
    assert data['nmt']['boot_ups'] == 3 and data['nmt']['commanded_boot_ups'] == 1
    assert data['nmt']['unexpected_restarts'] == 1


def test_each_injected_fault_is_a_finding(recording: FaultRecording, tmp_path: Path) -> None:
    data = report(recording.path, tmp_path)
    assert data['recording']['frames'] == recording.frames
    check_faults(data, recording, joint=None)
    # the mapping the trace configured (0x1A00 / 0x1600 writes) decodes the PDOs
    pdos = {row['cob_id']: row for row in data['pdo']}
    assert pdos['0x185']['mapping_source'] == 'trace' and pdos['0x205']['mapping_source'] == 'trace'
    assert pdos['0x205']['last_values']['0x607A:0 Target position'] == 12_345
    transitions = [(t['from'], t['to']) for t in data['cia402'][0]['transitions']]
    assert transitions[:4] == [('unknown', 'ready to switch on'), ('ready to switch on', 'switched on'),
                               ('switched on', 'operation enabled'), ('operation enabled', 'fault')]
    following = data['following_error']
    assert following and following[0]['demand_object'] == '0x607A'
    sync = data['sync']
    assert sync['count'] > 200 and abs(sync['nominal_s'] - PERIOD) < 0.2 * PERIOD
    assert sync['jitter_s']['p50'] <= sync['jitter_s']['p99'] <= sync['jitter_s']['max']
    assert data['busload']['peak_bits_per_s'] > 0


def test_a_bag_with_its_config_names_the_joint(recording: FaultRecording, tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    with BagWriter(bag, config_yaml=CONFIG_YAML) as writer:
        for msg in recording.messages:
            writer.write_frame(msg, 'vcan0')
    data = report(bag, tmp_path)
    assert data['recording']['format'] == 'rosbag2-mcap' and data['recording']['frames'] == recording.frames
    assert data['inputs']['config'].startswith('stored in')
    assert [(n['node'], n['name'], n['family']) for n in data['nodes']] == [(NODE, 'wrist_drive', 'generic_402')]
    check_faults(data, recording, joint='wrist_joint')
    # the drive holds position 0 against the target 12,345 counts: the error in rad from the scaling
    following = data['following_error'][0]
    assert following['joint'] == 'wrist_joint' and following['max_abs_counts'] == 12_345
    assert following['max_abs_si'] == pytest.approx(12_345 * 2 * math.pi / 65536)


def test_check_gives_the_exit_code(recording: FaultRecording, tmp_path: Path) -> None:
    rc, out = run(str(recording.path), '-o', str(tmp_path / 'r.html'), '--check')
    assert rc == 1
    assert 'heartbeat missing' in out and 'then boot-up: the drive rebooted' in out
    assert 'SDO 0x6060 (Modes of operation) write of 0x08 (8) aborted 0x06090030' in out
    clean = Path(__file__).resolve().parents[1] / '..' / 'shared' / 'realdata' / 'traces' / \
        'ros2_canopen_issue331_cia402_velocity_enable_excerpt.log'
    rc, out = run(str(clean), '-o', str(tmp_path / 'c.html'), '--check')
    assert rc == 0 and 'findings: 0 errors' in out


def test_bus_load_over_the_bit_rate(tmp_path: Path) -> None:
    """4 drives at 1 kHz (SYNC, RPDO and TPDO of 6 bytes each): about 810 kbit/s nominal."""
    path = tmp_path / 'busy.log'
    writer = can.CanutilsLogWriter(str(path), channel='can0')
    for msg in synthetic(20_000):
        writer.on_message_received(msg)
    writer.stop()
    data = report(path, tmp_path, '--bitrate', '1000000')
    load = one(data['findings'], 'bus-load')
    assert load['what'].startswith('bus load 81% of 1000 kbit/s') and 'queue' in load['cause']
    assert 0.80 < data['busload']['peak_load'] < 0.82
    assert data['busload']['peak_load_worst_stuffing'] > data['busload']['peak_load']
    quiet = report(path, tmp_path, '--bitrate', '2000000')
    assert not [f for f in quiet['findings'] if f['kind'] == 'bus-load']
