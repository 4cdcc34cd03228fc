"""Errors of streaming: a trajectory refused whole (validation, planning, the joints' state),
apart from the code that raises it so the layers that only catch it need not import it."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError


class TrajectoryError(DriveBridgeError, ValueError):
    """A trajectory refused as a whole; the message says why."""
