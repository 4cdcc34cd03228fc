"""``drive-bridge info``: what a bag or trace holds."""
from __future__ import annotations

import argparse
from pathlib import Path


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('bag', type=Path, help='bag directory, .mcap file or trace')


def run(args: argparse.Namespace) -> int:
    from drive_bridge.bag.info import info

    print(info(args.bag).text())
    return 0
