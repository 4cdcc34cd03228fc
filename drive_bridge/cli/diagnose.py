"""``drive-bridge diagnose``: a bag or trace (+ config / EDS) -> HTML report, JSON and a summary.

Only argparse is imported to configure the verb: the diagnosis and the readers are imported
when it runs, the HTML report's modules only when it is written.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from drive_bridge.cli.command import add_progress_option

FORMAT_NAMES = ('rosbag2-mcap', 'candump', 'candump-screen', 'trc', 'asc', 'blf', 'csv', 'sqlite', 'mf4',
                'ixxat-minimon')  # as drive_bridge.bag.formats.FORMATS (not imported for --help)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('input', type=Path, metavar='INPUT',
                        help='rosbag2 (directory or .mcap) or a CAN trace: candump -L log or pasted candump screen '
                             'output, .trc .asc .blf .csv, IXXAT MiniMon (the format is found from the content)')
    parser.add_argument('--format', choices=FORMAT_NAMES, metavar='FORMAT',
                        help=f'the input\'s format, when the content does not tell: {", ".join(FORMAT_NAMES)}')
    parser.add_argument('--config', type=Path, help='bus config YAML (default: the one stored in the bag, if any)')
    parser.add_argument('--eds', action='append', default=[], metavar='NODE=FILE',
                        help='EDS/DCF of a node, for object names and PDO defaults (repeatable)')
    parser.add_argument('--bitrate', type=int, help='bit rate in bit/s for the bus load (default: the config\'s)')
    parser.add_argument('-o', '--output', type=Path,
                        help='HTML report (default: INPUT\'s name + .diagnosis.html in the current directory)')
    parser.add_argument('--no-html', action='store_true', help='no HTML report: the summary (and --json) only')
    parser.add_argument('--json', type=Path, metavar='FILE', help='also write the diagnosis as JSON')
    parser.add_argument('--check', action='store_true', help='exit code 1 when there are error findings (for CI)')
    add_progress_option(parser)


def run(args: argparse.Namespace) -> int:
    from drive_bridge.bag.diagnose import diagnose, load_inputs
    from drive_bridge.bag.diagnose.errors import DiagnoseError
    from drive_bridge.bag.diagnose.inputs import parse_eds_args
    from drive_bridge.bag.diagnose.report_json import to_json
    from drive_bridge.bag.diagnose.summary import summary
    from drive_bridge.bag.source import open_recording

    recording = open_recording(args.input, fmt=args.format)
    inputs = load_inputs(recording, args.config, parse_eds_args(args.eds), args.bitrate)
    frames = recording.raw_frames()
    if not args.no_progress and sys.stderr.isatty():
        from tqdm import tqdm  # type: ignore[import-untyped]
        frames = tqdm(frames, unit=' frames', unit_scale=True, desc='diagnose', leave=False, mininterval=0.5)
    diagnosis = diagnose(recording, inputs, frames)
    data = to_json(diagnosis)
    output = None
    if not args.no_html:
        from drive_bridge.bag.diagnose.report_html import render  # only when writing HTML
        output = args.output or Path(f'{args.input.name}.diagnosis.html')
        _write(output, render(diagnosis, data), DiagnoseError)
    if args.json is not None:
        # compact: json's C encoder (an indent makes it the pure-Python one, 10x slower on a long log)
        _write(args.json, json.dumps(data, ensure_ascii=False, separators=(',', ':')) + '\n', DiagnoseError)
    print(summary(data, diagnosis))
    written = [f'report: {output}'] if output else []
    written += [f'JSON: {args.json}'] if args.json else []
    if written:
        print(', '.join(written))
    return 1 if args.check and data['summary']['error'] else 0


def _write(path: Path, text: str, error: type[Exception]) -> None:
    try:
        path.write_text(text, encoding='utf-8')
    except OSError as exc:
        raise error(f'{path}: cannot write: {exc.strerror or exc}') from exc
