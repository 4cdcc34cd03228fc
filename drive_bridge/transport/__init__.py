"""CAN transports of the package's own, as python-can interfaces.

``local``: a bus between the processes of one machine over Unix datagram sockets
(:mod:`drive_bridge.transport.local`). python-can finds it through the ``can.interface``
entry point once the package is installed; :data:`INTERFACES` lets the bridge open it
without the entry point.
"""
from __future__ import annotations

import can

from drive_bridge.transport.local import LocalBus

INTERFACES: dict[str, type[can.BusABC]] = {'local': LocalBus}

__all__ = ['INTERFACES', 'LocalBus']
