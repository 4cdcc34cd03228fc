"""Errors of the family boundary: an unknown family, and a drive parameter that could not be
read, written or saved (not a ROS parameter: that is ``ros.errors.NodeParameterRefused``)."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError


class FamilyError(DriveBridgeError, KeyError):
    """An unknown family name, or an entry point that does not load a DriveFamily."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ''


class ParameterError(DriveBridgeError):
    """A parameter could not be read, written or saved; ``str()`` says where and why.

    ``drive_text`` is the drive's own error text when the drive refused (else '').
    """

    def __init__(self, message: str, *, node_id: int | None = None, parameter: str = '',
                 drive_text: str = '') -> None:
        super().__init__(message)
        self.node_id = node_id
        self.parameter = parameter
        self.drive_text = drive_text
