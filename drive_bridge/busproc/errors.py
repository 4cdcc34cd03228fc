"""Errors of the boundary between the node process and the bus process."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError, RequestRefused


class BoundaryError(DriveBridgeError):
    """A message that cannot cross the boundary: too large, malformed, or of a type the
    boundary does not carry; ``str()`` says which and why."""


class BusProcessLost(RequestRefused):
    """The bus process is gone (it exited, was killed, or closed its side): every joint is
    unavailable and nothing reaches the drives. ``str()`` says how it ended."""


class Busy(RequestRefused):
    """Too many requests are running or waiting in the bus process already."""


class BusProcessStartError(DriveBridgeError):
    """The bus process could not start the bus (bad configuration, interface refused, ...);
    ``str()`` is the bus process's own message."""


class RemoteError(DriveBridgeError):
    """An error the bus process reported for a request whose kind has no exception class of
    its own on this side (``kind`` names the original class)."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind
