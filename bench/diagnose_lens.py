"""drive-bridge diagnose against canopen-lens (PyPI, pinned in requirements.in) in one run:

1. the corpus of real logs (test/data/traces/expectations.yaml): per log and in total, each
   tool's events right, found with a wrong cause, missed, and its false findings, side by side
   (lens reads candump only: it gets a candump -L copy of the TRC traces, made here with
   python-can, and the repository's converted copy of the MiniMon trace);
2. wall time (and CPU time) of both command-line tools on the same files: a 150,000-frame log
   (the real pcan3 trace repeated, as candump -L) and a 30-frame one (the first 30 frames of
   the ros2_canopen issue 225 log), plus `--help`: the best of --repeat runs of each, and
   each row's ratio to lens's time in the same run (the machine is shared: ratios compare).
   ``--baseline DIR`` also times another checkout of drive_bridge (DIR holds its
   ``drive_bridge/`` package, e.g. ``git archive main drive_bridge | tar -x -C DIR``) in the
   same run: before and after a change, under the same load.

    .venv/bin/python -m bench diagnose_lens [--repeat 3] [--frames 150000] [--no-corpus] [--baseline DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'test'))
from corpustools import SHARED, corpus, lens_found, ours_found, path_of, score  # noqa: E402

BIN = Path(sys.executable).parent
OURS = str(BIN / 'drive-bridge')
LENS = str(BIN / 'canopen-lens')


def candump_copy(source: Path, out: Path) -> Path:
    """A candump -L copy of a trace lens cannot read (python-can reads it; times as the trace has them)."""
    from drive_bridge.bag.source import open_recording
    with out.open('w') as stream:
        for msg in open_recording(source).frames():
            ident = f'{msg.arbitration_id:08X}' if msg.is_extended_id else f'{msg.arbitration_id:03X}'
            data = 'R' if msg.is_remote_frame else bytes(msg.data).hex().upper()
            stream.write(f'({msg.timestamp:.6f}) can0 {ident}#{data}\n')
    return out


def lens_input(log: dict[str, Any], tmp: Path) -> Path:
    path = path_of(log)
    if path.name == 'ixxat1.trc':
        return SHARED / 'ixxat1.converted.log'
    if path.suffix == '.trc':
        return candump_copy(path, tmp / f'{path.stem}.log')
    return path


def run_json(command: list[str], out: Path) -> dict[str, Any]:
    subprocess.run(command, check=False, capture_output=True, timeout=600)
    data: dict[str, Any] = json.loads(out.read_text(encoding='utf-8')) if out.exists() else {}
    return data


def side_by_side(tmp: Path) -> None:
    totals = {tool: [0, 0, 0, 0] for tool in ('ours', 'lens')}
    details: list[str] = []
    print(f'{"log":52} {"events":>6} | {"drive-bridge r/w/m/f":>21} | {"canopen-lens r/w/m/f":>21}')
    for log in corpus():
        ours_out, lens_out = tmp / f'{log["file"]}.ours.json', tmp / f'{log["file"]}.lens.json'
        ours = run_json([OURS, 'diagnose', str(path_of(log)), '--no-html', '--json', str(ours_out),
                         '--no-progress'], ours_out)
        lens = run_json([LENS, str(lens_input(log, tmp)), '-s', str(lens_out), '--no-color'], lens_out)
        cells = []
        for tool, data, found in (('ours', ours, ours_found(ours)), ('lens', lens, lens_found(lens))):
            s = score(log, tool, found, data)
            counts = [len(s.right), len(s.wrong), len(s.missed), len(s.false)]
            totals[tool] = [a + b for a, b in zip(totals[tool], counts)]
            cells.append('/'.join(map(str, counts)))
            name = 'drive-bridge' if tool == 'ours' else 'canopen-lens'
            details += [f'  {name}: {log["file"]}: {what} {", ".join(ids)}' for what, ids in
                        (('wrong', s.wrong), ('missed', s.missed)) if ids]
            details += [f'  {name}: {log["file"]}: false: {text}' for text in s.false]
        print(f'{log["file"][:52]:52} {len(log.get("events") or []):6d} | {cells[0]:>21} | {cells[1]:>21}')
    print('\n| | right | found, wrong cause/severity/outcome | missed | false findings |\n|---|---|---|---|---|')
    for tool, name in (('lens', 'canopen-lens 0.5.1'), ('ours', 'drive-bridge')):
        print(f'| {name} | ' + ' | '.join(map(str, totals[tool])) + ' |')
    print('\n'.join(['', 'what each tool got wrong, missed or said falsely:', *details]))


def big_log(frames: int, out: Path) -> Path:
    """The real pcan3 trace repeated (its times shifted on) to ``frames`` frames, as candump -L."""
    one = candump_copy(SHARED / 'pcan3.trc', out.with_suffix('.one'))
    lines = one.read_text().splitlines()
    start, end = float(lines[0][1:lines[0].index(')')]), float(lines[-1][1:lines[-1].index(')')])
    span = end - start + 1.0
    with out.open('w') as stream:
        n = 0
        rounds = 0
        while n < frames:
            for line in lines[:frames - n]:
                close = line.index(')')
                stream.write(f'({float(line[1:close]) + rounds * span:.6f}){line[close + 1:]}\n')
            n += min(len(lines), frames - n)
            rounds += 1
    return out


def timed(command: list[str], repeat: int, tmp: Path, env: dict[str, str] | None = None) -> tuple[float, float]:
    """(best wall s, CPU s of that run) of a command."""
    best = (float('inf'), 0.0)
    for _ in range(repeat):
        for leftover in tmp.glob('bag*'):
            shutil.rmtree(leftover, ignore_errors=True)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run(command, check=False, capture_output=True, timeout=600, cwd=tmp, env=env)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
        best = min(best, (wall, cpu))
    return best


def speed(tmp: Path, frames: int, repeat: int, baseline: Path | None = None) -> None:
    big = big_log(frames, tmp / 'big.log')
    small = tmp / 'small.log'
    small.write_text(''.join((path_of({'dir': 'test', 'file': 'ros2_canopen_225_boot_stall.log'})
                              .read_text().splitlines(keepends=True))[:30]))
    print(f'\nwall time, best of {repeat} (CPU time of that run) and its ratio to lens\'s wall time; {frames} and '
          f'30 frames; load average {os.getloadavg()[0]:.1f} at the start')
    print(f'{"":46} {f"{frames}-frame log":>30} {"30-frame log":>30}')
    ours = {'text + JSON': lambda f: ['diagnose', str(f), '--no-html', '--json', str(tmp / 'o.json'), '--no-progress'],
            '+ HTML report': lambda f: ['diagnose', str(f), '-o', str(tmp / 'o.html'), '--json', str(tmp / 'o.json'),
                                        '--no-progress'],
            'import (to a rosbag2 bag)': lambda f: ['import', str(f), '-o', str(tmp / 'bag'), '-q']}
    rows: list[tuple[str, Any, dict[str, str] | None]] = [
        ('canopen-lens (its analysis, JSON)', lambda f: [LENS, str(f), '-s', str(tmp / 'l.json'), '--no-color'], None)]
    for tag, env in [('drive-bridge', None)] + ([('baseline', {**os.environ, 'PYTHONPATH': str(baseline)})]
                                              if baseline else []):
        rows += [(f'{tag} {name}', lambda f, a=args: [OURS, *a(f)], env) for name, args in ours.items()]
    results: dict[str, list[tuple[float, float]]] = {}
    for name, command, env in rows:
        results[name] = [timed(command(f), repeat, tmp, env) for f in (big, small)]
        lens = results['canopen-lens (its analysis, JSON)']
        cells = [f'{wall:6.2f} s ({cpu:5.2f} s) {wall / ref[0]:4.1f}x' for (wall, cpu), ref in zip(results[name], lens)]
        print(f'{name:46} {cells[0]:>30} {cells[1]:>30}')
    for name, command_line in (('canopen-lens --help', [LENS, '--help']),
                               ('drive-bridge diagnose --help', [OURS, 'diagnose', '--help'])):
        wall, cpu = timed(command_line, repeat, tmp)
        print(f'{name:46} {f"{wall:6.2f} s ({cpu:5.2f} s)":>30}')
    lens_big, lens_small = results['canopen-lens (its analysis, JSON)']
    text = results['drive-bridge text + JSON']
    html = results['drive-bridge + HTML report']
    imp = results['drive-bridge import (to a rosbag2 bag)']
    print(f'\ngoals (wall): text/JSON <= lens on 150k: {text[0][0] / lens_big[0]:.1f}x lens; HTML <= 2x lens: '
          f'{html[0][0] / lens_big[0]:.1f}x; import <= 2x lens: {imp[0][0] / lens_big[0]:.1f}x; 30 frames <= lens + '
          f'0.3 s: lens + {html[1][0] - lens_small[0]:.2f} s (with HTML), + {text[1][0] - lens_small[0]:.2f} s '
          f'(text + JSON); load average {os.getloadavg()[0]:.1f} at the end')


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog='python -m bench diagnose_lens', description=__doc__.split('\n\n')[0])
    parser.add_argument('--repeat', type=int, default=3, help='runs per timed command (the best is shown)')
    parser.add_argument('--frames', type=int, default=150_000, help='frames of the long log')
    parser.add_argument('--no-speed', action='store_true', help='the corpus comparison only')
    parser.add_argument('--no-corpus', action='store_true', help='the timing only')
    parser.add_argument('--baseline', type=Path, metavar='DIR',
                        help='also time the drive_bridge package in DIR (PYTHONPATH=DIR), in the same run')
    args = parser.parse_args(argv)
    if not Path(LENS).exists():
        raise SystemExit(f'{LENS} is missing: canopen-lens is pinned in requirements.txt (tools/bootstrap.sh)')
    with tempfile.TemporaryDirectory() as tmp:
        if not args.no_corpus:
            side_by_side(Path(tmp))
        if not args.no_speed:
            speed(Path(tmp), args.frames, args.repeat, args.baseline)


if __name__ == '__main__':
    main()
