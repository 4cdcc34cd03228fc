"""What the parts of a simulated slave see of the node they belong to.

A :class:`~drive_bridge.sim.slave.SimulatedSlave` is composed, as canopen's LocalNode is, of
parts: the NMT state machine (:mod:`~drive_bridge.sim.nmtslave`), the heartbeat producer and
consumer (:mod:`~drive_bridge.sim.heartbeat`), the guarding responder
(:mod:`~drive_bridge.sim.guardresponder`), the SYNC clock (:mod:`~drive_bridge.sim.syncclock`) and the
SDO server over the object store (:mod:`~drive_bridge.sim.sdoserver`). Each part holds the node
through this protocol (never the slave module: no import back up) and calls the device
model's hooks through it, with the node's lock held.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Protocol

from drive_bridge.sim.emcy import EmcyProducer
from drive_bridge.sim.faults import CommFaults
from drive_bridge.sim.nmt import NmtCommand
from drive_bridge.sim.pdo import PdoEngine
from drive_bridge.sim.store import ObjectStore

Callback = Callable[[int, bytearray, float], None]


class SlaveNode(Protocol):
    """The node as its parts use it: identity, store, faults, sending and the hooks."""

    node_id: int
    name: str
    store: ObjectStore
    faults: CommFaults
    emcy: EmcyProducer
    pdo: PdoEngine
    options: dict[str, Any]
    NMT_COMMANDS: frozenset[NmtCommand]  # the NMT commands the device obeys

    @property
    def lock(self) -> threading.RLock: ...

    def send(self, cob: int, data: bytes) -> None: ...

    # hooks of the device model (documented on SimulatedSlave)
    def announce_bootup(self) -> None: ...

    def reset_application(self) -> None: ...

    def on_reset_communication(self) -> None: ...

    def on_boot(self) -> None: ...

    def model_step(self, dt: float, sync: bool) -> None: ...

    def supervise(self, now: float) -> bool: ...

    def on_heartbeat_lost(self, node: int) -> None: ...

    def on_heartbeat_recovered(self, node: int) -> None: ...

    def on_life_guarding_lost(self) -> None: ...

    def on_life_guarding_recovered(self) -> None: ...

    def answers_guarding(self) -> bool: ...

    def expedited_download(self, index: int, subindex: int, data: bytes, request: bytes) -> bytes: ...

    def refuse_sdo_request(self, request: bytes) -> int | None: ...
