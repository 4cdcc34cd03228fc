"""Errors of the bag tools: each names the file (and where in it) and what was wrong."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError


class BagError(DriveBridgeError):
    """A bag or trace could not be read, written or matched to its configuration."""


class OfflineSdoError(BagError):
    """A joint driver asked for an SDO transfer, which a recording cannot answer."""


class ScanError(BagError):
    """A scan that could not run (bad node range, no bus)."""
