"""Import: every real trace (expected counts from ../shared/realdata/SOURCES.md), every python-can
format, the IXXAT MiniMon reader against its candump conversion, and bad input of each kind."""
from __future__ import annotations

from pathlib import Path

import can
import pytest

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.importer import import_trace
from drive_bridge.bag.source import open_recording
from drive_bridge.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
# ../shared/realdata/traces next to the checkout (or further up, from a worktree)
TRACES = next((p / 'shared' / 'realdata' / 'traces' for p in ROOT.parents if (p / 'shared').is_dir()), ROOT)

# file -> (frames, node ids) as SOURCES.md states them
EXPECTED = {
    'pcan1.trc': (11283, {1, 15, 40, 90}),
    'pcan2.trc': (6968, {1, 10, 15, 30}),
    'pcan3.trc': (45422, {1, 10, 15, 40, 41, 42, 45, 85, 99, 112, 115}),
    'ixxat1.trc': (781, {1, 2, 3, 9}),
    'ixxat1.converted.log': (781, {1, 2, 3, 9}),
    'ros2_canopen_issue331_cia402_velocity_enable_excerpt.log': (28, {1, 2, 3, 4, 52}),
}
pytestmark = pytest.mark.skipif(not TRACES.is_dir(), reason='real traces not available')


@pytest.mark.parametrize('name', sorted(EXPECTED))
def test_every_real_trace_imports_with_its_frames_and_nodes(tmp_path: Path, name: str) -> None:
    frames, nodes = EXPECTED[name]
    report = import_trace(TRACES / name, tmp_path / 'bag', progress=False)
    assert (report.frames, set(report.nodes)) == (frames, nodes)
    assert report.warnings == ()
    bag = open_recording(tmp_path / 'bag')
    source = list(open_recording(TRACES / name).frames())
    imported = list(bag.frames())
    assert len(imported) == frames
    assert [(m.arbitration_id, bytes(m.data), m.dlc, m.is_remote_frame) for m in imported] == \
        [(m.arbitration_id, bytes(m.data), m.dlc, m.is_remote_frame) for m in source]
    assert all(abs(a.timestamp - b.timestamp) < 1e-6 for a, b in zip(imported, source, strict=True))


def test_minimon_reader_agrees_with_the_candump_conversion() -> None:
    minimon = list(open_recording(TRACES / 'ixxat1.trc').frames())
    candump = list(open_recording(TRACES / 'ixxat1.converted.log').frames())
    assert len(minimon) == len(candump) == 781
    for a, b in zip(minimon, candump, strict=True):
        assert (a.arbitration_id, bytes(a.data), a.is_remote_frame) == (b.arbitration_id, bytes(b.data),
                                                                         b.is_remote_frame)
        assert a.timestamp == pytest.approx(b.timestamp, abs=1e-9)
    remote = [m for m in minimon if m.is_remote_frame]
    # SOURCES.md: 40 guarding RTRs (37 on 0x709, 3 on 0x702); MiniMon keeps their DLC 1, candump's #R drops it
    assert len(remote) == 40 and {m.arbitration_id for m in remote} == {0x709, 0x702}
    assert all(m.dlc == 1 for m in remote)
    assert sum(1 for m in minimon if m.arbitration_id == 0x083 and m.dlc == 0) >= 1  # DLC-0 EMCY frames


@pytest.mark.parametrize('suffix', ['.asc', '.blf', '.csv', '.log', '.trc'])
def test_every_python_can_format_imports(tmp_path: Path, suffix: str) -> None:
    # (python-can's TRC writer does not write remote frames: data frames only)
    frames = [m for m in open_recording(TRACES / 'pcan2.trc').frames() if not m.is_remote_frame][:2000]
    trace = tmp_path / f'trace{suffix}'
    with can.Logger(trace) as logger:
        for msg in frames:
            logger(msg)
    assert main(['import', str(trace), '-o', str(tmp_path / 'bag'), '-q']) == 0
    imported = list(open_recording(tmp_path / 'bag').frames())
    assert [(m.arbitration_id, bytes(m.data)) for m in imported] == [(m.arbitration_id, bytes(m.data))
                                                                     for m in frames]


def test_import_stores_the_config_and_its_eds(tmp_path: Path) -> None:
    eds = tmp_path / 'eds' / 'io.eds'
    eds.parent.mkdir()
    eds.write_bytes((Path(__file__).parent / 'data' / 'configs' / 'io_module.eds').read_bytes())
    config = tmp_path / 'bus.yaml'
    config.write_text('bus: {interface: virtual, channel: x}\nnodes:\n  io: {node_id: 3, family: generic_301, '
                      'dcf: eds/io.eds}\n')
    report = import_trace(TRACES / 'ixxat1.trc', tmp_path / 'bag', config, progress=False)
    assert report.warnings == ()
    bag = open_recording(tmp_path / 'bag')
    assert bag.config_yaml == config.read_text()
    assert bag.files == {'eds/io.eds': eds.read_bytes()}


def test_a_config_whose_dcf_is_outside_its_directory_decodes_and_diagnoses_from_the_bag(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The shipped vendor examples name their EDS as ../../shared/...: the bag stores it under that
    path and the stored config loads again (replay --decode, diagnose) without the original files."""
    config = ROOT / 'config' / 'maxon_epos4_example.yaml'
    bag = tmp_path / 'imp331'
    trace = TRACES / 'ros2_canopen_issue331_cia402_velocity_enable_excerpt.log'
    assert main(['import', str(trace), '--config', str(config), '-o', str(bag), '-q']) == 0
    assert list(open_recording(bag).files) == ['../../shared/realdata/eds/maxon_epos4_0x1018.eds']
    capsys.readouterr()
    assert main(['replay', str(bag), '--decode', '-o', str(tmp_path / 'x')]) == 0, capsys.readouterr().err
    # the excerpt has no SYNC, the config a 4 ms cycle: said, not an empty /joint_states in silence
    assert ('warning: the config has master.sync_period 0.004 s but the recording holds no SYNC frame (0x080)'
            in capsys.readouterr().out)
    assert main(['diagnose', str(bag), '-o', str(tmp_path / 'r.html'), '--no-progress']) == 0, \
        capsys.readouterr().err
    decoded = tmp_path / 'decoded'  # a trace decoded with --config stores the config's EDS too
    assert main(['replay', str(trace), '--decode', '--config', str(config), '-o', str(decoded)]) == 0
    assert open_recording(decoded).files == open_recording(bag).files


def test_a_can_fd_frame_and_an_empty_trace_are_refused(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    fd = tmp_path / 'fd.log'
    fd.write_text('(1.000000) can0 701#05\n(1.100000) can0 181##1001122334455667788990011\n')
    assert main(['import', str(fd), '-o', str(tmp_path / 'a'), '-q']) == 2
    assert 'fd.log: frame 2 (id 0x181 at 1.100000) is a CAN FD frame' in capsys.readouterr().err
    empty = tmp_path / 'empty.log'
    empty.write_text('')
    assert main(['import', str(empty), '-o', str(tmp_path / 'b'), '-q']) == 2
    assert 'empty.log: the trace holds no frames' in capsys.readouterr().err
    assert not (tmp_path / 'a').exists() and not (tmp_path / 'b').exists()


def test_a_config_whose_nodes_are_not_in_the_trace_is_warned(tmp_path: Path) -> None:
    config = tmp_path / 'bus.yaml'
    config.write_text('bus: {interface: virtual, channel: x}\nnodes:\n  far: {node_id: 77, family: generic_402}\n')
    report = import_trace(TRACES / 'ixxat1.trc', tmp_path / 'bag', config, progress=False)
    assert any('77' in w and 'wrong config' in w for w in report.warnings)


def test_bad_inputs_are_clear_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    def fails(args: list[str], *words: str) -> None:
        assert main(args) == 2
        err = capsys.readouterr().err
        assert all(w in err for w in words), err
    out = str(tmp_path / 'out')
    fails(['import', str(tmp_path / 'missing.trc'), '-o', out], 'missing.trc', 'no such file')
    (tmp_path / 'x.pdf').write_bytes(b'%PDF')
    fails(['import', str(tmp_path / 'x.pdf'), '-o', out], 'x.pdf', "unknown format '.pdf'")
    truncated = tmp_path / 'cut.trc'
    text = (TRACES / 'pcan1.trc').read_text(encoding='latin-1')
    truncated.write_text(text[:20000] + '\n   999)  1234.5  Rx  0', encoding='latin-1')
    fails(['import', str(truncated), '-o', out, '-q'], 'cut.trc', 'unreadable line')
    assert not Path(out).exists()  # nothing half-written is left
    assert main(['import', str(truncated), '-o', out, '-q', '--skip-bad-lines']) == 0
    assert 'skipped' in capsys.readouterr().err
    fails(['import', str(truncated), '-o', out, '-q'], 'exists already')
    blf = tmp_path / 'garbage.blf'
    blf.write_bytes(b'LOGG' + bytes(range(256)) * 4)
    fails(['import', str(blf), '-o', str(tmp_path / 'o2'), '-q'], 'garbage.blf')
    whole = tmp_path / 'whole.blf'
    with can.Logger(whole) as logger:
        for msg in list(open_recording(TRACES / 'pcan2.trc').frames())[:3000]:
            logger(msg)
    cut = tmp_path / 'cut.blf'
    cut.write_bytes(whole.read_bytes()[:whole.stat().st_size // 2])
    fails(['import', str(cut), '-o', str(tmp_path / 'o5'), '-q'], 'cut.blf', 'truncated', 'BLF header says')
    minimon = tmp_path / 'bad_minimon.trc'
    lines = (TRACES / 'ixxat1.trc').read_text(encoding='latin-1').splitlines(keepends=True)
    lines[20] = '"00:02:21.20";"7G3";"Std";"";"7F "\n'
    minimon.write_text(''.join(lines), encoding='latin-1')
    fails(['import', str(minimon), '-o', str(tmp_path / 'o3'), '-q'], 'bad_minimon.trc', 'line 21',
          "identifier '7G3' is not hex")
    cut_minimon = tmp_path / 'head_minimon.trc'
    cut_minimon.write_text(''.join(lines[:4]), encoding='latin-1')
    fails(['import', str(cut_minimon), '-o', str(tmp_path / 'o4'), '-q'], 'truncated', 'column header')
    with pytest.raises(BagError, match='no metadata.yaml'):
        open_recording(tmp_path)


def test_a_trace_reader_closes_its_file_and_ignores_other_python_can_warnings(tmp_path: Path) -> None:
    import logging

    import psutil
    trace = (TRACES / 'pcan2.trc').resolve()
    frames = open_recording(trace).frames()
    next(frames)
    logging.getLogger('can.interfaces.socketcan').warning('an unrelated warning of python-can')
    assert sum(1 for _ in frames) == 6968 - 1  # not taken for an unreadable line of the trace
    frames = open_recording(trace).frames()
    next(frames)
    assert str(trace) in {f.path for f in psutil.Process().open_files()}
    frames.close()  # a consumer that stops early
    assert str(trace) not in {f.path for f in psutil.Process().open_files()}


def test_every_verb_has_one_help_and_one_spelling_of_no_progress(capsys: pytest.CaptureFixture[str]) -> None:
    from drive_bridge.cli.main import COMMANDS
    for verb, _, help_text in COMMANDS:
        with pytest.raises(SystemExit, match='0'):
            main([verb, '--help'])
        text = ' '.join(capsys.readouterr().out.split())
        assert ' '.join(help_text.split()) in text, verb  # the verb's page says what the listing says
        if verb in ('import', 'record', 'replay', 'diagnose'):
            assert '--no-progress' in text, verb
