"""Errors of the bag tools: each names the file (and where in it) and what was wrong."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError


class BagError(DriveBridgeError):
    """A bag or trace could not be read, written or matched to its configuration."""
