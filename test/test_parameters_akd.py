"""AKD parameters by their ASCII names, core level: the master and a simulated AKD on a virtual
bus (config/akd_pvt_example.yaml), the family's AkdParameters over the ASCII channel 0x2026.

Read / write / save, the checks made before anything is sent (range, type, access, unknown
names), the drive's own error texts, and the frames on the bus: 4-character expedited
downloads to 0x2026:1 and uploads of 0x2026:2, as in the manual's example (akd.md §9.11).
"""
from __future__ import annotations

import copy
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import yaml

from akdtools import Sniffer
from bustools import REPO, eventually, running, unique_channel
from drive_bridge.config import parse_bus_config
from drive_bridge.families.akd.parameter_table import AKD_PARAMETERS, ASCII_TABLE, read_parameter_table
from drive_bridge.families.akd.parameters import AkdParameters, parse_reply
from drive_bridge.families.errors import ParameterError
from drive_bridge.master.master import Master
from drive_bridge.sim.ascii_channel import PARAMETERS as SIM_PARAMETERS
from drive_bridge.sim.store import key

EXAMPLE = REPO / 'config' / 'akd_pvt_example.yaml'
NODE = 1
SDO_RX = 0x600 + NODE
SDO_TX = 0x580 + NODE


@dataclass
class Bench:
    master: Master
    sim: Any  # the simulated bus
    sniffer: Sniffer

    @property
    def drive(self) -> Any:
        return self.sim.drive(NODE)

    @property
    def access(self) -> AkdParameters:
        access = self.master.parameter_access(NODE)
        assert isinstance(access, AkdParameters)
        return access

    def channel_frames(self, after: int) -> list[bytes]:
        """The requests to the ASCII channel (0x2026) since ``after``."""
        return [f.data for f in self.sniffer.frames(SDO_RX, after) if f.data[1:3] == b'\x26\x20']


@pytest.fixture(scope='module')
def bench() -> Iterator[Bench]:
    data = yaml.safe_load(EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('akdparam')
    config = parse_bus_config(copy.deepcopy(data), 'akd_pvt_example.yaml', EXAMPLE.parent)
    sniffer = Sniffer(data['bus']['channel'])
    try:
        with running(config) as (master, sim):
            yield Bench(master, sim, sniffer)
    finally:
        sniffer.close()


def test_read_gives_number_unit_range_and_access(bench: Bench) -> None:
    value = bench.access.read('DRV.ACC')
    assert value.name == 'DRV.ACC' and value.value == bench.drive.value(0x3501)  # "1:1": SDO = ASCII value
    assert value.unit == 'counts/s^2'  # as the simulated drive prints it ([...])
    assert (value.minimum, value.maximum) == (-2 ** 31, 2 ** 31 - 1) and value.has_range
    assert value.access == 'rw' and value.save_needed
    current = bench.access.read('motor.icont')  # names are case-insensitive
    assert current.name == 'MOTOR.ICONT' and current.value == pytest.approx(bench.drive.value(0x358E) / 1000)
    assert current.unit == 'A' and current.maximum == pytest.approx(4294967.295)
    faults = bench.access.read('DRV.FAULTS')  # the manual's example command
    assert faults.value_text == 'No faults active' and faults.value is None and not faults.save_needed
    assert bench.access.read('VL.FB').access == 'ro'


def test_write_sends_the_value_and_reads_it_back(bench: Bench) -> None:
    written = bench.access.write('MOTOR.ICONT', '2.5')
    assert written.value == 2.5 and written.value_text == '2.500' and written.save_needed
    assert bench.drive.value(0x358E) == 2500  # "1000:1": the object holds 1000 x the ASCII value
    assert bench.access.write('DRV.DEC', '2000000').value == 2000000 == bench.drive.value(0x3522)
    bitrate = bench.access.write('FBUS.PARAM01', '1000')
    assert bitrate.value == 1000 and 'restart' in bitrate.note
    assert bench.access.write('FBUS.PARAM01', '125').value == 125


@pytest.mark.parametrize('name, value, reason', [
    ('DRV.ACC', '5e9', 'DRV.ACC: 5e9 is above the maximum 2147483647 '),
    ('CS.DEC', '-1', 'CS.DEC: -1 is below the minimum 0 '),
    ('MOTOR.ICONT', '1.2345', 'MOTOR.ICONT: 1.2345 has more than 3 decimals'),
    ('DIN1.MODE', '1.5', 'DIN1.MODE: 1.5 is not an integer'),
    ('DRV.DEC', 'fast', "DRV.DEC: 'fast' is not a number"),
    ('DRV.DEC', '', 'DRV.DEC: no value given'),
    ('DRV.DEC', '10\r\nDRV.EN', 'characters the ASCII channel cannot carry'),
    ('VL.FB', '0', 'VL.FB: is read-only'),
    ('FBUS.PARAM01', '300', 'FBUS.PARAM01: 300 is not one of 0, 125, 250, 500, 1000'),
    ('DRV.NVSAVE', '1', 'DRV.NVSAVE: is a command and takes no value'),
])
def test_a_bad_write_is_refused_before_anything_is_sent(bench: Bench, name: str, value: str, reason: str) -> None:
    mark = bench.sniffer.mark
    with pytest.raises(ParameterError) as refused:
        bench.access.write(name, value)
    assert str(refused.value).startswith(f'node {NODE} (akd): ') and reason in str(refused.value), refused.value
    assert refused.value.node_id == NODE and refused.value.drive_text == ''
    assert bench.channel_frames(mark) == []


def test_unknown_names_are_refused_with_suggestions(bench: Bench) -> None:
    mark = bench.sniffer.mark
    with pytest.raises(ParameterError, match=r'node 1 \(akd\): DRV\.ACCC: unknown AKD parameter; did you mean '
                                             r'DRV\.ACC'):
        bench.access.read('DRV.ACCC')
    with pytest.raises(ParameterError, match='unknown AKD parameter; the table has'):
        bench.access.read('XYZZY')
    with pytest.raises(ParameterError, match='drive_object must be 0, not 1'):
        bench.access.read('DRV.ACC', drive_object=1)
    with pytest.raises(ParameterError, match='DRV.STOP: is a command and cannot be read'):
        bench.access.read('DRV.STOP')
    assert bench.channel_frames(mark) == []


def test_the_drives_error_text_becomes_the_error(bench: Bench) -> None:
    # a control command over the ASCII channel while the fieldbus controls the drive (akd.md §4.1)
    with pytest.raises(ParameterError) as refused:
        bench.access.write('DRV.STOP', '')
    assert refused.value.drive_text == 'Error: Drive is controlled by the fieldbus (FBUS.REMOTE = 1)'
    assert "node 1 (akd): DRV.STOP: the drive refused 'DRV.STOP': Error: Drive is controlled" in str(refused.value)
    # names outside the table go to the drive only when asked for, and the drive answers
    unlisted = AkdParameters(bench.master.nodes['akd'], allow_unlisted=True)
    with pytest.raises(ParameterError, match="DRV.NOSUCH: the drive refused 'DRV.NOSUCH': Error: Unknown command"):
        unlisted.read('DRV.NOSUCH')
    assert unlisted.read('DRV.ACC').value == bench.access.read('DRV.ACC').value  # the same channel still works


def test_save_keeps_values_over_a_reset_node_and_unsaved_ones_are_lost(bench: Bench) -> None:
    access = bench.access
    access.write('HOME.DIST', '1234')
    message = access.save()
    assert 'DRV.NVSAVE' in message and 'node 1 (akd)' in message
    access.write('HOME.DIST', '99')  # not saved
    boots = bench.master.nodes['akd'].boot_attempts
    bench.master.nmt(0x81, NODE)  # reset node: the drive reloads what was saved (akd.md §10.14)
    eventually(lambda: bench.master.nodes['akd'].boot_attempts > boots and bench.master.nodes['akd'].available,
               10, 'node 1 configured again after its reset')
    bench.master.wait_until_operational(10)
    assert access.read('HOME.DIST').value == 1234
    assert bench.drive.value(0x3484) == 1234


def test_frames_are_four_character_chunks_to_2026_1_and_reads_of_2026_2(bench: Bench) -> None:
    mark = bench.sniffer.mark
    bench.access.read('DRV.ACC')
    requests = bench.channel_frames(mark)
    downloads = [f for f in requests if f[3] == 1]
    uploads = [f for f in requests if f[3] == 2]
    assert downloads and all(f[0] & 0xE3 == 0x23 for f in downloads), 'expedited, size indicated'
    sizes = [4 - (f[0] >> 2 & 3) for f in downloads]
    assert sizes == [4, 4, 1]
    assert b''.join(f[4:4 + n] for f, n in zip(downloads, sizes)) == b'DRV.ACC\r\n'
    assert downloads[0] == b'\x23\x26\x20\x01DRV.', "the manual's first frame: 601: 23 26 20 01 44 52 56 2E"
    assert uploads and all(f == b'\x40\x26\x20\x02\x00\x00\x00\x00' for f in uploads)
    def reply() -> bytes:  # the sniffer may log the last answer after the read has returned
        answers = [f.data for f in bench.sniffer.frames(SDO_TX, mark) if f.data[1:4] == b'\x26\x20\x02']
        return b''.join(a[4:4 + 4 - (a[0] >> 2 & 3)] for a in answers)
    eventually(lambda: reply().endswith(b'\n\r\n'), 2, 'the whole reply on the bus')
    assert reply().startswith(b'>') and b'[counts/s^2]' in reply()


class _Port:
    """A fake node for the channel logic alone: scripted chunks."""

    node_id = 9

    def __init__(self, chunks: list[bytes], name: str = 'fake') -> None:
        self.name = name  # the channel state (lock, broken transaction) is per node id and name
        self.chunks = chunks
        self.sent: list[bytes] = []

    def sdo_write_raw(self, index: int, subindex: int, data: bytes) -> None:
        self.sent.append(data)

    def sdo_read_raw(self, index: int, subindex: int) -> bytes:
        return self.chunks.pop(0) if self.chunks else b'xxxx'


def test_a_reply_without_terminator_is_cut_off_and_named() -> None:
    port = _Port([])
    with pytest.raises(ParameterError, match=r'node 9 \(fake\): DRV.ACC: the reply to .DRV.ACC. did not end '
                                             r'\(no "\\r\\n"\) within 64 characters'):
        AkdParameters(port, max_reply=64).read('DRV.ACC')
    # the next transaction first spoils whatever the broken one left in the drive's buffer
    port.chunks = [b'>Err', b'or\n\r', b'\n', b'>3\n\r', b'\n']
    port.sent.clear()
    assert AkdParameters(port).read('MOTOR.POLES').value == 3
    assert b''.join(port.sent) == b'~\r\nMOTOR.POLES\r\n'


def test_parse_reply_strips_prompt_and_terminator() -> None:
    assert parse_reply('>No faults active\n\r\n') == 'No faults active'
    assert parse_reply('>\r\n') == ''
    assert parse_reply('-->-12.500 [A]\n\r\n') == '-12.500 [A]'
    port = _Port([b'>-12', b'.500', b' [A]', b'\n\r\n'], name='fake2')
    value = AkdParameters(port).read('IL.LIMITN')
    assert (value.value, value.unit, value.value_text) == (-12.5, 'A', '-12.500')
    assert b''.join(port.sent) == b'IL.LIMITN\r\n' and all(len(c) <= 4 for c in port.sent)


def _table_lines() -> list[str]:
    lines = ASCII_TABLE.read_text(encoding='utf-8').splitlines()
    return [line for line in lines if line.strip() and not line.lstrip().startswith('#')]


def test_every_row_of_the_shipped_table_parses_in_the_bridge_and_the_simulator(bench: Bench) -> None:
    """One table (families/akd/data/akd_ascii_parameters.txt), read by both: no line is lost, each
    row becomes an object of the simulated drive, and every readable one is read over the bus
    (the simulator answering, the bridge parsing its answer)."""
    lines = _table_lines()
    assert len(lines) == len(AKD_PARAMETERS) == len(SIM_PARAMETERS) == 316
    assert [line.split()[0] for line in lines] == list(AKD_PARAMETERS) == list(SIM_PARAMETERS)
    access = bench.access
    for name, spec in AKD_PARAMETERS.items():
        sim = SIM_PARAMETERS[name]
        assert (sim.kind, sim.scale, sim.access, sim.choices) == (spec.kind, spec.scale, spec.access, spec.choices)
        if spec.index and spec.kind != 'cmd':
            assert sim.keys[0] == key(spec.index, spec.subindex), name
            assert all(k in bench.drive.store for k in sim.keys), f'{name}: not in the simulated dictionary'
        else:
            assert sim.keys == (), name
        if spec.access in ('wo', 'cmd'):
            continue
        value = access.read(name)
        if spec.numeric:
            raw = bench.drive.value(spec.index, spec.subindex) if len(sim.keys) == 1 else None
            assert value.value is not None, f'{name}: {value.value_text!r}'
            assert raw is None or value.value == pytest.approx(raw / max(1, spec.scale)), name
        assert value.unit == (sim.unit or spec.unit), name  # the unit the simulated drive prints wins


# (name, object, type, scaling, access, the bridge's unit, the simulator's unit, volatile/restart/choices)
# as akd.md prints them: §8.3 (blank access = rw, INTEGER = i32), §1.2 for the bit rates
_MANUAL = [
    ('DRV.ACC', (0x3501, 0), 'i32', 1, 'rw', 'acceleration units', 'counts/s^2', ''),
    ('VL.FB', (0x3618, 0), 'i32', 1, 'ro', 'velocity units', 'counts/s', ''),
    ('CAP0.PLFB', (0x20A6, 0), 'i32', -1, 'ro', 'position units', 'counts', ''),
    ('MOTOR.ICONT', (0x358E, 0), 'u32', 1000, 'rw', 'A', 'A', ''),
    ('IL.FRICTION', (0x3422, 0), 'u32', 1000, 'rw', 'A', 'A', ''),  # access printed blank
    ('DRV.HWENMODE', (0x3506, 0), 'i32', 0, 'rw', '', '', ''),  # "INTEGER", access blank
    ('VL.ARZQ4', (0x3406, 16), 'u32', 1000, 'rw', '', '', ''),  # sub-index printed "D-10" (hex)
    ('WS.IMAX', (0x3494, 1), 'i16', 1000, 'rw', 'A', 'A', ''),
    ('MOTOR.BRAKERLS', (0x3450, 0), 'u8', 0, 'wo', '', '', ''),
    ('MOTOR.R', (0x3456, 0), 'u32', 1000, 'rw', 'Ohm', 'Ohm', ''),
    ('FB1.ORIGIN', (0x3656, 0), 'u64', 1, 'rw', 'position units', 'counts', ''),
    ('AOUT.VALUEU', (0x3470, 3), 'i16', 1000, 'rw', 'V', 'V', 'v'),
    ('DRV.NVSAVE', (0x35EB, 0), 'cmd', 0, 'cmd', '', '', ''),
    ('FBUS.PARAM01', (0x36E5, 0), 'u32', 0, 'rw', '', '', 'r 0/125/250/500/1000'),
    ('FBUS.PARAM04', (0x36E8, 0), 'u32', 0, 'rw', '', '', '0/1'),
    ('VL.OBSBW', (0x51BA, 0), 'u32', 0, 'rw', 'Hz', 'Hz', ''),
    ('FAULT702.ACTION', (0x525D, 0), 'u32', 0, 'rw', '', '', ''),
]


@pytest.mark.parametrize('name, obj, kind, scale, acc, unit, sim_unit, flags', _MANUAL, ids=[r[0] for r in _MANUAL])
def test_rows_as_the_manual_prints_them(name: str, obj: tuple[int, int], kind: str, scale: int, acc: str, unit: str,
                                        sim_unit: str, flags: str) -> None:
    spec, sim = AKD_PARAMETERS[name], SIM_PARAMETERS[name]
    choices = next((tuple(int(c) for c in f.split('/')) for f in flags.split() if '/' in f), ())
    assert ((spec.index, spec.subindex), spec.kind, spec.scale, spec.access, spec.unit) == (obj, kind, scale, acc, unit)
    assert (spec.volatile, spec.restart, spec.choices) == ('v' in flags.split(), 'r' in flags.split(), choices)
    assert (sim.kind, sim.scale, sim.access, sim.unit, sim.choices) == (kind, scale, acc, sim_unit, choices)
    assert spec.save_needed == (acc == 'rw' and 'v' not in flags.split())


def test_the_64_bit_io_parameters_are_split_over_low_and_high_sub_indices() -> None:
    # akd.md §8.3: 0x3474 subs 1-7 / 8-E (DIN1-7.PARAM), 0x3475 subs 1-2 / 3-4 (DOUT1-2.PARAM)
    assert SIM_PARAMETERS['DIN1.PARAM'].keys == (key(0x3474, 1), key(0x3474, 8))
    assert SIM_PARAMETERS['DIN7.PARAM'].keys == (key(0x3474, 7), key(0x3474, 0xE))
    assert SIM_PARAMETERS['DOUT2.PARAM'].keys == (key(0x3475, 2), key(0x3475, 4))
    assert AKD_PARAMETERS['DIN7.PARAM'].limits == (0, 2 ** 64 - 1)


@pytest.mark.parametrize('line, problem', [
    ('DRV.ACC 3501:0 i33 1 rw acc', "type 'i33' is not one of"),
    ('DRV.ACC 3501:0 i32 10 rw acc', "scaling '10' is not one of -, 1, 1000, var"),
    ('DRV.ACC 3501:0 i32 1 RW acc', "access 'RW' is not one of"),
    ('DRV.ACC 0x3501 i32 1 rw acc', "object '0x3501' is not INDEX:SUB"),
    ('DRV.ACC 3501:0 i32 1 rw acc x', "flag 'x' is not v, r or choices=a/b/c"),
    ('DRV.ACC 3501:0 i32 1 rw acc choices=1/two', "flag 'choices=1/two'"),
    ('DRV.ACC 3501:0 i32 1 rw', 'has 5 of the 6 columns'),
    ('VL.FB 3618:0 i32 1 ro vel', 'VL.FB is listed twice'),
])
def test_a_bad_table_line_is_refused_with_its_place(tmp_path: Path, line: str, problem: str) -> None:
    table = tmp_path / 'table.txt'
    table.write_text('# a header\n\nVL.FB 3618:0 i32 1 ro vel\n' + line + '\n', encoding='utf-8')
    with pytest.raises(ValueError, match='^table.txt:4: ') as refused:
        read_parameter_table({}, table)
    assert problem in str(refused.value), refused.value
    table.write_text('# a header\nVL.FB 3618:0 i32 1 ro vel\n  # an indented comment\nDRV.FAULTS 0:0 text - ro -\n')
    rows = read_parameter_table({'vel': 'rev/s'}, table)  # each reader names the user units its own way
    assert list(rows) == ['VL.FB', 'DRV.FAULTS'] and rows['VL.FB'].unit == 'rev/s' and rows['DRV.FAULTS'].unit == ''
