"""The hooks of a simulated slave, each with plain CiA 301 as its default.

:class:`~drive_bridge.sim.slave.SimulatedSlave` derives from :class:`SlaveHooks`; a device model
or a drive family's simulator overrides the hooks where its manual says the device differs
(the list is in SimulatedSlave's docstring). The parts of the slave call them with the
slave's lock held.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from drive_bridge.sim.emcy import EmcyProducer
from drive_bridge.sim.guarding import EMCY_LIFE_GUARD
from drive_bridge.sim.nmt import HEARTBEAT_BASE

EMCY_HEARTBEAT = 0x8130


class SlaveHooks:
    """The overridable behaviour of a simulated slave, with the CiA 301 defaults."""

    node_id: int
    options: dict[str, Any]
    emcy: EmcyProducer

    send: Callable[[int, bytes], None]  # the slave's: a frame sent as this node

    # ---- heartbeat consumer and life guarding hooks ------------------------------------
    def on_heartbeat_lost(self, node: int) -> None:
        """Hook: the heartbeat of producer ``node`` (the master) timed out. Default: EMCY
        0x8130 with the node in byte 3; drives add their fault reaction."""
        self.emcy.error(EMCY_HEARTBEAT, 'heartbeat', manufacturer=bytes([node]))

    def on_heartbeat_recovered(self, node: int) -> None:
        """Hook: a lost producer's heartbeat is back. Default: its error is gone (EMCY 0x0000
        when no other error is left)."""
        self.emcy.clear('heartbeat')

    def on_life_guarding_lost(self) -> None:
        """Hook: no guarding RTR for the life time 0x100C x 0x100D (life guarding armed).
        Default after the option ``life_guarding_reaction``: 'emcy' sends EMCY 0x8130 (error
        register bit 4 until the RTRs resume), 'none' does nothing."""
        if self.options['life_guarding_reaction'] != 'none':
            self.emcy.error(EMCY_LIFE_GUARD, 'guarding')

    def on_life_guarding_recovered(self) -> None:
        """Hook: RTRs arrive again after a life guarding event, or a reset ends it. Default:
        its error is gone."""
        self.emcy.clear('guarding')

    def answers_guarding(self) -> bool:
        """Hook: whether guarding RTRs are answered (and feed life guarding) now. Default: always
        (a device that uses heartbeat instead while 0x1017 != 0 says no then)."""
        return True

    def life_time_limit(self) -> float:
        """Hook: s, the longest node life time the device supports (0x100C x 0x100D is clamped
        to it). Default: no limit."""
        return math.inf

    # ---- device model hooks (subclasses) ---------------------------------------------
    def announce_bootup(self) -> None:
        """Hook: boot-up on the bus. Default (CiA 301): 0x700 + node with one byte 0x00."""
        self.send(HEARTBEAT_BASE + self.node_id, b'\x00')

    def reset_application(self) -> None:
        """Hook: power-on or NMT reset node, the device application starts again."""

    def on_reset_communication(self) -> None:
        """Hook: power-on, NMT reset node or reset communication: communication state starts again."""

    def on_boot(self) -> None:
        """Hook: boot-up sent, PRE-OPERATIONAL entered."""

    def model_step(self, dt: float, sync: bool) -> None:
        """Hook: advance the device model by ``dt`` s; ``sync`` when triggered by a SYNC frame."""

    def supervise(self, now: float) -> bool:
        """Hook: the device's own periodic checks (every tick while booted, ``now`` monotonic);
        True when they changed what an event-driven TPDO may carry."""
        return False

    def expedited_download(self, index: int, subindex: int, data: bytes, request: bytes) -> bytes:
        """Hook: the data of an expedited SDO download (``request``: its frame) before the
        CiA 301 checks. A device that accepts other sizes than the object's fits them here."""
        return data

    def refuse_sdo_request(self, request: bytes) -> int | None:
        """Hook: the abort code with which the device answers the SDO request frame ``request``
        instead of serving it (the abort frame repeats the request's bytes 1..3). Default: None,
        every request is served (canopen's server: expedited, segmented, block)."""
        return None
