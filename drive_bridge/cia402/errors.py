"""Errors of the CiA 402 axis, apart from the axis code that raises them."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint.errors import JointError


class AxisError(JointError):
    """An intent on a CiA 402 axis that could not be carried out; the message says why."""


class SetpointRefused(DriveBridgeError):
    """A direct command the cycle check would refuse (raised as the axis' AxisError)."""
