"""The command-line tools: ``bridge``/``bridge_managed`` (one bus node) and ``drive-bridge``
(the tool with subcommands: see :mod:`drive_bridge.cli.main`)."""
from __future__ import annotations

from drive_bridge.cli.bridge import bridge_main, bridge_managed_main

__all__ = ['bridge_main', 'bridge_managed_main']
