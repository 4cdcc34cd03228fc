"""Fault-injection switches of a simulated slave.

The switches are plain data consulted on the slave's send/receive paths; the public
methods that flip them live on :class:`~drive_bridge.sim.slave.SimulatedSlave`
(``mute``, ``set_sdo_delay``, ``abort_sdo_on``, ...) and, for drive faults, on
:class:`~drive_bridge.sim.drive402.SimDrive402` (``inject_fault``,
``clear_fault_cause``). They exist so the master's error paths can be tested against
a bus participant that misbehaves exactly like a broken real device.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass, field


@dataclass
class CommFaults:
    """Communication faults; all off by default."""

    muted: bool = False  # a dead node: no SDO, PDO, heartbeat, guarding, EMCY, boot-up; ignores every frame
    sdo_delay: float = 0.0  # s each SDO response is held back (sent from the slave's timer thread)
    sdo_aborts: dict[tuple[int, int], int] = field(default_factory=dict)  # (index, sub) -> abort code
    heartbeat_stopped: bool = False  # heartbeat producer silent, everything else works
    boot_delay: float = 0.0  # s from power-on / reset to the boot-up frame
    drop_rpdos: bool = False  # received RPDOs ignored (the drive stops following the master)
    guarding_silent: bool = False  # RTRs received (life guarding fed) but not answered
    guarding_toggle_repeated: bool = False  # guarding replies repeat the last reply's toggle bit


class CommFaultInjection:
    """Public fault-injection methods of a slave (mixed into SimulatedSlave, which
    provides ``_lock`` and ``faults``)."""

    _lock: threading.RLock
    faults: CommFaults

    def mute(self, on: bool = True) -> None:
        """A dead node: no SDO answer, no PDO, heartbeat, guarding reply, EMCY; incoming frames ignored."""
        with self._lock:
            self.faults.muted = bool(on)

    def set_sdo_delay(self, seconds: float) -> None:
        """Hold every SDO response back ``seconds`` (scheduled: the bus keeps running)."""
        with self._lock:
            self.faults.sdo_delay = max(0.0, float(seconds))

    def abort_sdo_on(self, index: int, subindex: int, code: int | None) -> None:
        """Answer every SDO access to (index, subindex) with abort ``code``; None removes it."""
        with self._lock:
            if code is None:
                self.faults.sdo_aborts.pop((index, subindex), None)
            else:
                self.faults.sdo_aborts[(index, subindex)] = int(code)

    def stop_heartbeat(self) -> None:
        """The heartbeat producer falls silent; everything else keeps working."""
        with self._lock:
            self.faults.heartbeat_stopped = True

    def start_heartbeat(self) -> None:
        with self._lock:
            self.faults.heartbeat_stopped = False

    def set_boot_delay(self, seconds: float) -> None:
        """Boot-up frame ``seconds`` late after the next power-on or reset."""
        with self._lock:
            self.faults.boot_delay = max(0.0, float(seconds))

    def drop_rpdos(self, on: bool = True) -> None:
        """Ignore received RPDOs (a drive that stopped following the master)."""
        with self._lock:
            self.faults.drop_rpdos = bool(on)

    def stop_guarding_replies(self, on: bool = True) -> None:
        """The node keeps running but no longer answers guarding RTRs (the master's node
        guarding must time out); the RTRs still feed the node's own life guarding."""
        with self._lock:
            self.faults.guarding_silent = bool(on)

    def repeat_guarding_toggle(self, on: bool = True) -> None:
        """Guarding replies carry the same toggle bit as the last reply: a guarding error
        the master must detect (CiA 301: the toggle alternates with every reply)."""
        with self._lock:
            self.faults.guarding_toggle_repeated = bool(on)
