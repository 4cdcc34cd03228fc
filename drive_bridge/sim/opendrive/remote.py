"""The simulated OPEN drive's RTR-only TPDOs (transmission types 252/253): the remote frames it
listens for follow the TPDOs' COB-IDs, and a remote frame is answered with the PDO's sample."""
from __future__ import annotations

import logging
import threading
from collections.abc import Callable

import can

from drive_bridge.sim.guarding import RemoteFrames
from drive_bridge.sim.opendrive.pdo import OpenDrivePdoEngine

logger = logging.getLogger(__name__)


class RemoteTpdos:
    """Keeps the remote-frame subscriptions of one drive; ``serving()``: the node answers now."""

    def __init__(self, name: str, frames: Callable[[], RemoteFrames | None], pdo: OpenDrivePdoEngine,
                 lock: threading.RLock, serving: Callable[[], bool]) -> None:
        self._name = name
        self._frames = frames
        self._pdo = pdo
        self._lock = lock
        self._serving = serving
        self._cobs: set[int] = set()

    def update(self) -> None:
        """The TPDOs' parameters changed, or the node booted: listen for their COB-IDs."""
        frames = self._frames()
        wanted = self._pdo.remote_cob_ids() if frames is not None else set()
        if frames is not None:
            for cob in self._cobs - wanted:
                frames.remove(cob)
            for cob in wanted - self._cobs:
                frames.add(cob, self._on_request)
        self._cobs = wanted

    def _on_request(self, msg: can.Message) -> None:
        try:
            with self._lock:
                if self._serving():
                    self._pdo.on_remote_request(msg.arbitration_id)
        except Exception:  # never let an exception stop the shared Notifier
            logger.exception('%s: RTR-only TPDO failed', self._name)

    def detach(self) -> None:
        """The node leaves the bus: no remote frame is listened for."""
        frames = self._frames()
        if frames is not None:
            for cob in self._cobs:
                frames.remove(cob)
        self._cobs = set()
