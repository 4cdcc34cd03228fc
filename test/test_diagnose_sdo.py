"""The SDO log pairs block transfers (CiA 301 §7.2.4.3.9-16): the sub-block segments, whose
first byte is a sequence number, are data, not new requests."""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

from drive_bridge.cli.main import main

FRAMES = [  # (COB-ID, payload): node 5, a block upload, a block download, an expedited read
    (0x605, 'A40810007F000000'), (0x585, 'C60810000A000000'), (0x605, 'A300000000000000'),
    (0x585, '01' + b'drive-t'.hex()), (0x585, '82' + b'est'.hex() + '00000000'),
    (0x605, 'A2027F0000000000'), (0x585, 'D1AAAA0000000000'), (0x605, 'A100000000000000'),
    (0x605, 'C6501F0109000000'), (0x585, 'A4501F017F000000'), (0x605, '01' + b'1234567'.hex()),
    (0x605, '82' + b'89'.hex() + '0000000000'), (0x585, 'A2027F0000000000'), (0x605, 'D5BBBB0000000000'),
    (0x585, 'A100000000000000'),
    (0x605, '4000100000000000'), (0x585, '4300100092010200'),
]


def test_block_transfers_are_paired(tmp_path: Path) -> None:
    path = tmp_path / 'block.log'
    path.write_text(''.join(f'({1.0 + i * 0.001:.6f}) can0 {cob:03X}#{data}\n' for i, (cob, data) in enumerate(FRAMES)))
    js = tmp_path / 'r.json'
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(path), '-o', str(tmp_path / 'r.html'), '--json', str(js), '--no-progress']) == 0
    data = json.loads(js.read_text())
    rows = [(t['object'], t['access'], t['status'], t['transfer'], t['value']) for t in data['sdo']['transactions']]
    assert rows == [
        ('0x1008:0 Manufacturer device name', 'read', 'ok', 'block', "'drive-test'"),
        ('0x1F50:1', 'write', 'ok', 'block', "'123456789'"),
        ('0x1000:0 Device type', 'read', 'ok', 'expedited', '0x00020192 (131474)')]
    assert data['sdo']['transactions'][0]['latency_ms'] == 7.0
    identity = data['nodes'][0]['identity']
    assert identity['device name'] == 'drive-test' and identity['profile'] == 'CiA 402 drive'
    assert not data['findings']


def test_a_mode_the_drive_does_not_take(tmp_path: Path) -> None:
    """0x6060 = 8 (csp) written and confirmed, 0x6061 still 3 (pv) 1.5 s later: a finding."""
    frames = [(1.0, 0x605, '2F60600008000000'), (1.001, 0x585, '6060600000000000'),
              (2.5, 0x605, '4061600000000000'), (2.501, 0x585, '4F61600003000000')]
    path = tmp_path / 'mode.log'
    path.write_text(''.join(f'({t:.6f}) can0 {cob:03X}#{data}\n' for t, cob, data in frames))
    js = tmp_path / 'r.json'
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(path), '-o', str(tmp_path / 'r.html'), '--json', str(js), '--no-progress']) == 0
    data = json.loads(js.read_text())
    [finding] = data['findings']
    assert finding['kind'] == 'cia402-mode' and finding['node'] == 5 and finding['time'] == 0.001  # confirmed
    assert finding['what'] == 'axis 1: mode of operation csp (8) requested, the drive shows pv (3)'
    assert data['cia402'][0]['modes'] == [{'time': 1.501, 'mode': 'pv'}]
