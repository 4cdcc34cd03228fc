"""Errors of the S120 family, apart from the boot steps that raise them."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError


class S120BootError(DriveBridgeError):
    """A boot step found the drive unusable as configured (the message says how to fix it)."""
