"""``drive-bridge recover``: make the split a killed recorder left open readable."""
from __future__ import annotations

import argparse
from pathlib import Path


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('bag', type=Path, help='bag directory (or one .mcap split)')


def run(args: argparse.Namespace) -> int:
    from drive_bridge.bag.recover import recover

    print(recover(args.bag).summary())
    return 0
