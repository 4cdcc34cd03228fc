"""Errors of the ``drive-bridge`` subcommands (printed as one line, exit code 2)."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError


class CommandError(DriveBridgeError):
    """A subcommand cannot do its work (the message names the input and the cause)."""
