"""A simulated slave's place on a canopen Network: its subscriptions and the frames it sends."""
from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import canopen

from drive_bridge.sim.faults import CommFaults
from drive_bridge.sim.guarding import RemoteFrames
from drive_bridge.sim.parts import Callback

logger = logging.getLogger('drive_bridge.sim.slave')

NOTIFIER_CYCLE = 0.05  # s: Notifier recv timeout of own Networks (canopen's 1 s makes disconnect slow)


def open_network(channel: Any, **bus_options: Any) -> canopen.Network:
    """A connected Network of its own on the ``virtual`` bus ``channel``."""
    network = canopen.Network()
    network.NOTIFIER_CYCLE = NOTIFIER_CYCLE
    network.connect(interface='virtual', channel=channel, receive_own_messages=False, **bus_options)
    return network


class NodeBus:
    """The Network a node is on (None: not attached), what it subscribed there, what it sent."""

    def __init__(self, name: str, faults: CommFaults, powered: Callable[[], bool]) -> None:
        self._name = name
        self._faults = faults
        self._powered = powered
        self.network: canopen.Network | None = None
        self.owned = False  # the Network is the node's own (disconnected on close)
        self._subscriptions: list[tuple[int, Callback]] = []
        self.frames_sent = 0  # frames this node put on the bus (for frame-loss checks)

    def subscribe(self, cob: int, callback: Callback) -> None:
        if self.network is not None:
            self.network.subscribe(cob, callback)
            self._subscriptions.append((cob, callback))

    def unsubscribe(self, cob: int, callback: Callback) -> None:
        if (cob, callback) in self._subscriptions:
            self._subscriptions.remove((cob, callback))
            if self.network is not None:
                try:
                    self.network.unsubscribe(cob, callback)
                except (KeyError, ValueError):
                    pass

    def unsubscribe_all(self) -> None:
        for cob, callback in list(self._subscriptions):
            self.unsubscribe(cob, callback)

    def send(self, cob: int, data: bytes) -> None:
        """Send a frame as this node (nothing while powered off or muted)."""
        network = self.network
        if self._faults.muted or not self._powered() or network is None or network.bus is None:
            return
        try:
            network.send_message(cob, data)
            self.frames_sent += 1
        except Exception as exc:  # bus shut down under us while stopping
            logger.debug('%s: send 0x%03X failed: %s', self._name, cob, exc)

    def remote_frames(self) -> RemoteFrames | None:
        notifier = getattr(self.network, 'notifier', None)
        return None if notifier is None else RemoteFrames.of(notifier)
