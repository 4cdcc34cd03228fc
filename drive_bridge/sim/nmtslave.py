"""The NMT slave of a simulated node: its state, the boot sequence and the NMT commands.

canopen's NmtSlave neither sends the boot-up frame again after a reset received from the
master nor gates the other services; this one does both. The other parts of the slave ask it
whether they may act (:attr:`NmtSlave.booted`, :attr:`NmtSlave.communicating`) and the
slave wires what a reset and a boot-up do to them (``Sequence``).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from drive_bridge.sim.nmt import NmtCommand, NmtState, addressed_command
from drive_bridge.sim.parts import SlaveNode
from drive_bridge.sim.timers import TimerHandle, TimerThread

Step = Callable[[], None]


@dataclass(frozen=True)
class Sequence:
    """What the other parts do in the boot sequence (all called with the lock held)."""

    reset_guarding: Step  # entering INITIALISING: guarding starts again (its event ends)
    stop_heartbeat: Step  # entering INITIALISING: no heartbeat until boot-up
    load_communication: Step  # before boot-up: PDOs, SYNC subscription, heartbeat consumer from the store
    restart_heartbeat: Step  # PRE-OPERATIONAL entered: the producer follows 0x1017


class NmtSlave:
    """NMT state of one node (OFF while powered off), with the boot-up after the boot delay."""

    def __init__(self, node: SlaveNode, timers: TimerThread, sequence: Sequence) -> None:
        self._node = node
        self._timers = timers
        self._sequence = sequence
        self.state = NmtState.OFF
        self._boot_handle: TimerHandle | None = None

    @property
    def powered(self) -> bool:
        return self.state is not NmtState.OFF

    @property
    def booted(self) -> bool:
        """Past boot-up: heartbeat, guarding and NMT commands are served."""
        return self.state not in (NmtState.OFF, NmtState.INITIALISING)

    @property
    def communicating(self) -> bool:
        """PRE-OPERATIONAL or OPERATIONAL: SDO, SYNC and EMCY are served."""
        return self.state in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL)

    @property
    def operational(self) -> bool:
        return self.state is NmtState.OPERATIONAL

    def power_on(self) -> None:
        """Power-on: the application starts and the node initialises (caller checked it was OFF)."""
        self._reset_objects(application=True)
        self.enter_initialising()

    def power_off(self) -> None:
        """Silent at once; the pending boot-up is cancelled."""
        self.state = NmtState.OFF
        if self._boot_handle is not None:
            self._boot_handle.cancel()

    def enter_initialising(self) -> None:
        node = self._node
        if self.state is NmtState.OPERATIONAL:
            node.pdo.leave_operational()
        self.state = NmtState.INITIALISING
        self._sequence.reset_guarding()
        node.on_reset_communication()
        self._sequence.stop_heartbeat()
        if self._boot_handle is not None:
            self._boot_handle.cancel()
        self._boot_handle = self._timers.call_later(node.faults.boot_delay, self._boot)

    def _boot(self) -> None:
        node = self._node
        with node.lock:
            if self.state is not NmtState.INITIALISING:
                return
            self._boot_handle = None
            self._sequence.load_communication()
            node.announce_bootup()
            self.state = NmtState.PRE_OPERATIONAL
            self._sequence.restart_heartbeat()
            node.on_boot()

    def _reset_objects(self, application: bool) -> None:
        node = self._node
        if application:
            node.store.reset()
            node.emcy.reset()
            node.reset_application()
        else:
            node.store.reset(0x1000, 0x1FFF)

    def reset(self, application: bool) -> None:
        """NMT reset node (``application``) or reset communication."""
        self._reset_objects(application)
        self.enter_initialising()

    def on_command(self, can_id: int, data: bytearray, timestamp: float) -> None:
        """Notifier thread: a frame on COB-ID 0 (an NMT command; others' are ignored)."""
        node = self._node
        with node.lock:
            if node.faults.muted or not self.booted:
                return
            command = addressed_command(bytes(data), node.node_id)
            if command is None or command not in node.NMT_COMMANDS:
                return
            if command is NmtCommand.START:
                self.set_state(NmtState.OPERATIONAL)
            elif command in (NmtCommand.STOP, NmtCommand.ENTER_PRE_OPERATIONAL):
                self.set_state(NmtState.STOPPED if command is NmtCommand.STOP else NmtState.PRE_OPERATIONAL)
            elif command is NmtCommand.RESET_NODE:
                self.reset(application=True)
            elif command is NmtCommand.RESET_COMMUNICATION:
                self.reset(application=False)

    def set_state(self, state: NmtState) -> None:
        """OPERATIONAL, STOPPED or PRE-OPERATIONAL (PDOs start or stop); ignored unless booted."""
        if not self.booted or state == self.state:
            return
        if state not in (NmtState.OPERATIONAL, NmtState.STOPPED, NmtState.PRE_OPERATIONAL):
            raise ValueError(f'{self._node.name}: {state!r} is not a state a node enters by command')
        if self.state is NmtState.OPERATIONAL:
            self._node.pdo.leave_operational()
        self.state = state
        if state is NmtState.OPERATIONAL:
            self._node.pdo.enter_operational()
