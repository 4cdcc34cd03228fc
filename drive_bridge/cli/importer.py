"""``drive-bridge import``: a vendor trace (or another bag) into the bag layout the bridge records."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drive_bridge.cli.command import add_progress_option


def configure(parser: argparse.ArgumentParser) -> None:
    from drive_bridge.cli.diagnose import FORMAT_NAMES
    parser.add_argument('trace', type=Path,
                        help='the trace: candump -L or pasted candump screen output, any format python-can reads, '
                             'IXXAT MiniMon (the format is found from the content)')
    parser.add_argument('--format', choices=FORMAT_NAMES, metavar='FORMAT',
                        help=f'the trace\'s format, when the content does not tell: {", ".join(FORMAT_NAMES)}')
    parser.add_argument('-o', '--output', type=Path, required=True, help='bag directory to create')
    parser.add_argument('--config', type=Path, help='bus configuration YAML to store with the frames')
    parser.add_argument('--skip-bad-lines', action='store_true',
                        help='skip lines the reader cannot parse (with a warning) instead of failing')
    add_progress_option(parser, '-q', '--quiet')


def run(args: argparse.Namespace) -> int:
    from drive_bridge.bag.importer import import_trace

    report = import_trace(args.trace, args.output, args.config, progress=not args.no_progress,
                          strict=not args.skip_bad_lines, fmt=args.format)
    print(report.summary())
    for warning in report.warnings:
        print(f'drive-bridge import: warning: {warning}', file=sys.stderr)
    return 0
