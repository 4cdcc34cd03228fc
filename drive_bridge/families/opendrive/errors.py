"""Errors of the OPEN drive family, apart from the driver and boot steps that raise them."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint.errors import JointError


class OpenDriveBootError(DriveBridgeError):
    """A boot step of an OPEN drive found the drive unusable (the message says how to fix it)."""


class RunLogicError(JointError):
    """An intent on an OPEN drive axis that could not be carried out."""
