"""Errors of the joint-driver protocol, apart from the drivers that raise them."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError


class JointError(DriveBridgeError):
    """An intent that could not be carried out; the message names the joint and says why."""
