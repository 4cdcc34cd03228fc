"""Errors of the package's own CAN transports."""
from __future__ import annotations

import can

from drive_bridge.errors import DriveBridgeError


class TransportError(DriveBridgeError, can.CanError):
    """A local bus cannot be opened or used (the message names the channel and the cause)."""
