"""The node guarding responder of a simulated slave: answers guarding RTRs on 0x700 + node
and watches the master in turn (life guarding), with :class:`~drive_bridge.sim.guarding.NodeGuarding`
keeping the toggle and the life time."""
from __future__ import annotations

import logging
import time

import can
import canopen

from drive_bridge.sim.guarding import NodeGuarding, RemoteFrames
from drive_bridge.sim.nmt import HEARTBEAT_BASE
from drive_bridge.sim.nmtslave import NmtSlave
from drive_bridge.sim.parts import SlaveNode

logger = logging.getLogger('drive_bridge.sim.slave')


class GuardingResponder:
    """RTR listener on the bus Notifier, guarding replies and the life guarding events."""

    def __init__(self, node: SlaveNode, nmt: NmtSlave, guarding: NodeGuarding) -> None:
        self._node = node
        self._nmt = nmt
        self.guarding = guarding
        self._notifier: can.Notifier | None = None  # the Notifier whose RTR frames reach this node

    def listen(self, network: canopen.Network | None) -> None:
        """Listen on ``network``'s Notifier (once it is connected; again after a reconnect)."""
        notifier = getattr(network, 'notifier', None)
        if notifier is None or notifier is self._notifier:
            return
        self.stop_listening()
        RemoteFrames.of(notifier).add(HEARTBEAT_BASE + self._node.node_id, self._on_request)
        self._notifier = notifier

    def stop_listening(self) -> None:
        notifier, self._notifier = self._notifier, None
        if notifier is not None:
            RemoteFrames.of(notifier).remove(HEARTBEAT_BASE + self._node.node_id)

    @property
    def lost(self) -> bool:
        """Life guarding event raised and no RTR since."""
        return self.guarding.lost

    def rearm(self, now: float) -> None:
        """Life guarding, if armed, counts its life time from ``now`` (a device whose guarding
        pauses, e.g. while its output stage is off); an event raised ends without the hook."""
        if self.guarding.last_request is not None:
            self.guarding.request(now)

    def reset(self) -> None:
        """INITIALISING entered: life guarding starts again, its event is over (no frame while initialising)."""
        if self.guarding.lost:
            self._node.on_life_guarding_recovered()
        self.guarding.reset()

    def check(self, now: float) -> bool:
        """Tick while booted: True when life guarding was just lost (the hook has run)."""
        changed = self.guarding.expired(now)
        if changed:
            self._node.on_life_guarding_lost()
        return changed

    def _on_request(self, msg: can.Message) -> None:
        """Notifier thread: an RTR on 0x700 + node. Answered in every booted NMT state."""
        node = self._node
        try:
            with node.lock:
                if node.faults.muted or not self._nmt.booted:
                    return
                if not node.answers_guarding():
                    return
                if not node.faults.guarding_silent:
                    reply = self.guarding.reply(int(self._nmt.state), node.faults.guarding_toggle_repeated)
                    node.send(HEARTBEAT_BASE + node.node_id, reply)
                if self.guarding.request(time.monotonic()):
                    node.on_life_guarding_recovered()
        except Exception:  # never let an exception stop the shared Notifier
            logger.exception('%s: node guarding reply failed', node.name)
