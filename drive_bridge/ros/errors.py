"""Errors of the ROS layer: the node cannot start, or a client's message, goal, command or
parameter is refused (the node keeps running). Apart from the modules that raise them, so a
module that only catches one need not import the code that raises it."""
from __future__ import annotations

from drive_bridge.errors import DriveBridgeError, RequestRefused

__all__ = ['AccessRefused', 'GoalRefused', 'MalformedMessage', 'MessageTooLarge',
           'NodeParameterRefused', 'NonFinite', 'PoolBusy', 'RequestRefused', 'StartupError']


class StartupError(DriveBridgeError, RuntimeError):
    """The node cannot start: bad parameters or configuration (the message says what)."""


class NodeParameterRefused(DriveBridgeError, ValueError):
    """One or more of the node's ROS parameters are invalid (or start-time ones set while it
    runs); the message lists each. Not a drive's parameter: that is
    :class:`drive_bridge.families.errors.ParameterError`."""


class AccessRefused(RequestRefused):
    """Refused by the bus config's ``access`` rules; ``rule`` is the config key that refused it
    (``access.sdo_write``), and ``str()`` names it with the reason."""

    def __init__(self, rule: str, message: str) -> None:
        super().__init__(message)
        self.rule = rule


class PoolBusy(RequestRefused):
    """Too many requests are running or waiting for the bus already (the pool's limit)."""


class GoalRefused(ValueError):
    """A goal the bridge will not execute; ``code`` is the Result error code to answer."""

    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code = code


class MessageTooLarge(DriveBridgeError, ValueError):
    """A message over a size limit; refused before it is deserialized."""


class MalformedMessage(DriveBridgeError, ValueError):
    """Serialized bytes that are not a message of the expected type."""


class NonFinite(RequestRefused, ValueError):
    """A message field holds NaN or an infinity where a number is needed."""
