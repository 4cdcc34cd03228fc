"""The package's one error base class: every error the bridge raises on purpose derives from it,
so an integrator can catch ``DriveBridgeError`` and know the message names what was wrong."""
from __future__ import annotations


class DriveBridgeError(Exception):
    """Base of every drive_bridge error (config, SDO, boot, joint, trajectory, parameter)."""


class RequestRefused(DriveBridgeError):
    """A client's request refused before anything reached the bus (access rules, a full queue,
    the bus process gone); ``str()`` says why. The node keeps running."""
