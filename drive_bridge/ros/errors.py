"""Errors of the ROS layer: a client's request refused (the node keeps running)."""
from __future__ import annotations

from drive_bridge.errors import RequestRefused

__all__ = ['AccessRefused', 'PoolBusy', 'RequestRefused']


class AccessRefused(RequestRefused):
    """Refused by the bus config's ``access`` rules; ``rule`` is the config key that refused it
    (``access.sdo_write``), and ``str()`` names it with the reason."""

    def __init__(self, rule: str, message: str) -> None:
        super().__init__(message)
        self.rule = rule


class PoolBusy(RequestRefused):
    """Too many requests are running or waiting for the bus already (the pool's limit)."""
