"""Errors of the diagnosis: bad inputs named with the file and what was wrong."""
from __future__ import annotations

from drive_bridge.bag.errors import BagError


class DiagnoseError(BagError):
    """The recording, config or EDS given to ``diagnose`` cannot be used (and why)."""
