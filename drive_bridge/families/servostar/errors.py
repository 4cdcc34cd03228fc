"""Errors of the SERVOSTAR family, apart from the boot steps that raise them."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError


class ServostarBootError(DriveBridgeError):
    """A boot step found the drive's settings unusable (the message names the parameter)."""
