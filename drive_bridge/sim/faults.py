"""Fault-injection switches of a simulated slave.

The switches are plain data consulted on the slave's send/receive paths; the public
methods that flip them live on :class:`~drive_bridge.sim.slave.SimulatedSlave`
(``mute``, ``set_sdo_delay``, ``abort_sdo_on``, ...) and, for drive faults, on
:class:`~drive_bridge.sim.drive402.SimDrive402` (``inject_fault``,
``clear_fault_cause``). They exist so the master's error paths can be tested against
a bus participant that misbehaves exactly like a broken real device.
:class:`FaultyBus` does the same for the bus itself (bus-off, failing interface).
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import can


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
    tpdos_stopped: bool = False  # no TPDO sent, heartbeat and SDO go on (a stuck application)


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

    def stop_tpdos(self, on: bool = True) -> None:
        """The node sends no TPDO any more while its heartbeat and SDO server go on."""
        with self._lock:
            self.faults.tpdos_stopped = bool(on)

    def repeat_guarding_toggle(self, on: bool = True) -> None:
        """Guarding replies carry the same toggle bit as the last reply: a guarding error
        the master must detect (CiA 301: the toggle alternates with every reply)."""
        with self._lock:
            self.faults.guarding_toggle_repeated = bool(on)


class FaultyBus(can.BusABC):
    """A python-can bus in front of a real one (e.g. ``virtual``) that fails on demand like
    a broken interface or controller: bus-off (send and receive raise, the state is ERROR,
    frames on the wire are missed), a number of failing receives or sends, error frames.
    Hand it to the master as its bus to test what the master does on a bad bus."""

    def __init__(self, inner: can.BusABC) -> None:
        self._inner = inner
        self._lock = threading.Lock()
        self._off = False
        self._recv_failures = 0
        self._send_failures = 0
        self._error_frames = 0
        self.missed = 0  # frames dropped while bus-off
        super().__init__(channel=getattr(inner, 'channel', None) or '')
        self.channel_info = f'faulty {inner.channel_info}'

    # -- switches ---------------------------------------------------------------------------
    def bus_off(self, on: bool = True) -> None:
        """Bus-off: every send and receive raises CanOperationError until switched back."""
        with self._lock:
            self._off = bool(on)

    def fail_receives(self, count: int) -> None:
        """The next ``count`` receives raise (a glitching interface)."""
        with self._lock:
            self._recv_failures = max(0, int(count))

    def fail_sends(self, count: int) -> None:
        """The next ``count`` sends raise (e.g. a full transmit queue)."""
        with self._lock:
            self._send_failures = max(0, int(count))

    def error_frames(self, count: int = 1) -> None:
        """The next ``count`` receives return error frames (as a controller reports them)."""
        with self._lock:
            self._error_frames += max(0, int(count))

    # -- bus --------------------------------------------------------------------------------
    @property  # type: ignore[misc]  # read-only: the state follows the switches
    def state(self) -> can.BusState:
        return can.BusState.ERROR if self._off else can.BusState.ACTIVE

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        with self._lock:
            if self._off:
                raise can.CanOperationError('bus-off: transmit refused by the controller')
            if self._send_failures:
                self._send_failures -= 1
                raise can.CanOperationError('transmit buffer full')
        self._inner.send(msg, timeout)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        with self._lock:
            if self._off:
                while self._inner.recv(0) is not None:  # the wire goes on without us
                    self.missed += 1
                raise can.CanOperationError('bus-off: controller not receiving')
            if self._recv_failures:
                self._recv_failures -= 1
                raise can.CanOperationError('receive failed: interface glitch')
            if self._error_frames:
                self._error_frames -= 1
                return can.Message(arbitration_id=0x20000004, is_error_frame=True, dlc=8,
                                   data=b'\x00\x00\x04\x00\x00\x00\x00\x00', timestamp=time.time()), True
        return self._inner.recv(timeout), True

    def shutdown(self) -> None:
        super().shutdown()
        self._inner.shutdown()
