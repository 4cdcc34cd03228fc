"""What one ``drive-bridge`` subcommand module provides (one module per subcommand)."""
from __future__ import annotations

import argparse
from typing import Protocol


class Subcommand(Protocol):
    """A module of :mod:`drive_bridge.cli` that ``drive-bridge`` lists in ``COMMANDS``.

    ``NAME`` is the verb, ``HELP`` its one-line help; ``configure`` adds the verb's
    arguments; ``run`` does the work and returns the process exit code. Bad input is
    raised as a :class:`drive_bridge.errors.DriveBridgeError`, which the tool prints as one
    line naming what was wrong (exit code 2), never as a traceback.
    """

    NAME: str
    HELP: str

    def configure(self, parser: argparse.ArgumentParser) -> None: ...

    def run(self, args: argparse.Namespace) -> int: ...
