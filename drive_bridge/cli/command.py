"""What one ``drive-bridge`` subcommand module provides (one module per subcommand)."""
from __future__ import annotations

import argparse
from typing import Protocol


def add_progress_option(parser: argparse.ArgumentParser, *aliases: str) -> None:
    """Every verb spells it ``--no-progress`` (``args.no_progress``); ``aliases`` keep older spellings."""
    parser.add_argument('--no-progress', *aliases, dest='no_progress', action='store_true',
                        help='no progress bar or line')


class Subcommand(Protocol):
    """A module of :mod:`drive_bridge.cli` that ``drive-bridge`` lists in ``COMMANDS``.

    The verb and its one-line help are its line in ``COMMANDS`` (main.py); ``configure`` adds
    the verb's arguments (the parser's description is that help already); ``run`` does the
    work and returns the process exit code. Bad input is raised as a
    :class:`drive_bridge.errors.DriveBridgeError`, which the tool prints as one line naming
    what was wrong (exit code 2), never as a traceback.
    """

    def configure(self, parser: argparse.ArgumentParser) -> None: ...

    def run(self, args: argparse.Namespace) -> int: ...
