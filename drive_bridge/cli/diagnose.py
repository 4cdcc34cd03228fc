"""``drive-bridge diagnose``: a bag or trace (+ config / EDS) -> HTML report, JSON and a summary."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from tqdm import tqdm  # type: ignore[import-untyped]

from drive_bridge.bag.diagnose import diagnose, load_inputs
from drive_bridge.bag.diagnose.errors import DiagnoseError
from drive_bridge.bag.diagnose.inputs import parse_eds_args
from drive_bridge.bag.diagnose.report_json import to_json
from drive_bridge.bag.diagnose.summary import summary
from drive_bridge.bag.source import open_recording
from drive_bridge.cli.command import add_progress_option


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('input', type=Path, metavar='INPUT',
                        help='rosbag2 (directory or .mcap) or a CAN trace (.trc .asc .blf .log .csv, IXXAT MiniMon)')
    parser.add_argument('--config', type=Path, help='bus config YAML (default: the one stored in the bag, if any)')
    parser.add_argument('--eds', action='append', default=[], metavar='NODE=FILE',
                        help='EDS/DCF of a node, for object names and PDO defaults (repeatable)')
    parser.add_argument('--bitrate', type=int, help='bit rate in bit/s for the bus load (default: the config\'s)')
    parser.add_argument('-o', '--output', type=Path,
                        help='HTML report (default: INPUT\'s name + .diagnosis.html in the current directory)')
    parser.add_argument('--json', type=Path, metavar='FILE', help='also write the diagnosis as JSON')
    parser.add_argument('--check', action='store_true', help='exit code 1 when there are error findings (for CI)')
    add_progress_option(parser)


def run(args: argparse.Namespace) -> int:
    recording = open_recording(args.input)
    inputs = load_inputs(recording, args.config, parse_eds_args(args.eds), args.bitrate)
    frames = tqdm(recording.frames(), unit=' frames', unit_scale=True, desc='diagnose', leave=False,
                  disable=True if args.no_progress else None, mininterval=0.5)
    diagnosis = diagnose(recording, inputs, frames)
    data = to_json(diagnosis)
    from drive_bridge.bag.diagnose.report_html import render  # matplotlib: only when writing HTML
    output = args.output or Path(f'{args.input.name}.diagnosis.html')
    _write(output, render(diagnosis, data))
    if args.json is not None:
        _write(args.json, json.dumps(data, indent=1, ensure_ascii=False) + '\n')
    print(summary(data, diagnosis.findings))
    print(f'report: {output}' + (f', JSON: {args.json}' if args.json else ''))
    return 1 if args.check and data['summary']['error'] else 0


def _write(path: Path, text: str) -> None:
    try:
        path.write_text(text, encoding='utf-8')
    except OSError as exc:
        raise DiagnoseError(f'{path}: cannot write: {exc.strerror or exc}') from exc
