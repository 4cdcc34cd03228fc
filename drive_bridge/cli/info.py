"""``drive-bridge info``: what a bag or trace holds."""
from __future__ import annotations

import argparse
from pathlib import Path

NAME = 'info'
HELP = 'show the topics, types, counts, duration and stored files of a bag (or the frames of a trace)'


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('bag', type=Path, help='bag directory, .mcap file or trace')


def run(args: argparse.Namespace) -> int:
    from drive_bridge.bag.info import info

    print(info(args.bag).text())
    return 0
