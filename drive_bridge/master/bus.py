"""Opening the CAN bus, with a tap that sees every frame in both directions.

python-can has no hook for sent frames, so the bridge's bus is a thin proxy
(:class:`TappedBus`) in front of the real interface: every ``send`` and every
``recv`` is reported to the tap's listeners. canopen's Network is built on the proxy,
so SDO, NMT, SYNC and PDO traffic all pass through it.

The proxy is also where bus faults are contained: an exception from the interface's
``recv`` would end canopen's Notifier thread (the master would go deaf without a word),
so it is caught, counted and reported (:class:`BusHealth`); error frames are counted and
kept from canopen; a failed ``send`` is counted and raised to its caller, except in
periodic tasks (the master heartbeat), which keep running until the bus returns.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import can
from can.broadcastmanager import CyclicSendTaskABC, ThreadBasedCyclicSendTask

from drive_bridge.transport import INTERFACES

FrameListener = Callable[[can.Message], None]
BusFaultListener = Callable[[str], None]
FAULT_REPORT_INTERVAL = 1.0  # s between two reports of bus faults (each is counted)
RECV_ERROR_BACKOFF = 0.05  # s the Notifier waits after a failed recv (no busy loop on a dead bus)
BUS_ERRORS = (can.CanError, OSError, ValueError)  # what python-can interfaces raise on a bad bus


@dataclass(frozen=True)
class BusHealth:
    """What the tapped bus has seen go wrong, for diagnostics and the master's supervision."""

    failing: bool  # the last receive or send failed, or the controller reports bus-off / error
    recv_errors: int
    send_errors: int
    error_frames: int
    last_error: str
    last_ok: float  # monotonic time of the last successful receive or send (0 = never)
    failing_since: float  # monotonic time the current failure began (0 = not failing)


class FrameTap:
    """Fans frames out to listeners; a failing listener is reported once, not raised."""

    def __init__(self) -> None:
        self._listeners: list[FrameListener] = []
        self._lock = threading.Lock()
        self.errors: list[str] = []

    def add_listener(self, listener: FrameListener) -> None:
        with self._lock:
            self._listeners = [*self._listeners, listener]

    def remove_listener(self, listener: FrameListener) -> None:
        with self._lock:
            # ``!=``, not ``is not``: each ``obj.method`` access is a new bound method, equal to the last
            self._listeners = [x for x in self._listeners if x != listener]

    def __len__(self) -> int:
        """How many listeners are attached (a detached recorder must not stay on the bus threads)."""
        return len(self._listeners)

    def __call__(self, msg: can.Message) -> None:
        for listener in self._listeners:
            try:
                listener(msg)
            except Exception as exc:  # a broken consumer must not break the bus
                if len(self.errors) < 100:
                    self.errors.append(f'{listener!r}: {exc!r}')


class TappedBus(can.BusABC):
    """A bus proxy that reports sent (``is_rx=False``) and received frames to a tap."""

    def __init__(self, inner: can.BusABC, tap: FrameTap, on_fault: BusFaultListener | None = None) -> None:
        self._inner = inner
        self._tap = tap
        self._on_fault = on_fault
        self._health_lock = threading.Lock()
        self.recv_errors = self.send_errors = self.error_frames = 0
        self.last_error = ''
        self._failing_since = 0.0
        self._last_ok = 0.0
        self._last_report = -FAULT_REPORT_INTERVAL
        super().__init__(channel=getattr(inner, 'channel', None) or '')  # no filters: the inner bus filters
        self.channel_info = f'tapped {inner.channel_info}'

    # periodic sends (e.g. the master heartbeat) use BusABC's thread task, which calls
    # send() and so passes the tap; send_periodic_by_interface passes through to the inner bus

    @property
    def inner(self) -> can.BusABC:
        return self._inner

    def replace_inner(self, inner: can.BusABC) -> None:
        """Swap in a reopened interface (the old one is shut down); the Notifier keeps its thread."""
        old, self._inner = self._inner, inner
        try:
            old.shutdown()
        except Exception:  # a dead interface may fail to close: it is dropped anyway
            pass

    # -- health -----------------------------------------------------------------------------
    def _fault(self, what: str, exc: BaseException) -> None:
        text = f'{what} failed on {self._inner.channel_info}: {exc!r}'
        now = time.monotonic()
        with self._health_lock:
            self.last_error = text
            first = not self._failing_since
            if first:
                self._failing_since = now
            report = first and now - self._last_report >= FAULT_REPORT_INTERVAL
            if report:
                self._last_report = now
        if report and self._on_fault is not None:  # counted always, reported at most every second
            self._on_fault(text)

    def _ok(self) -> None:
        now = time.monotonic()
        self._last_ok = now
        if self._failing_since and self._controller_ok():
            with self._health_lock:
                self._failing_since = 0.0

    def _controller_ok(self) -> bool:
        try:
            return self._inner.state is not can.BusState.ERROR
        except Exception:  # an interface without a state
            return True

    def health(self) -> BusHealth:
        controller_ok = self._controller_ok()
        with self._health_lock:
            if not self._failing_since and not controller_ok:  # bus-off without a failed call yet
                self._failing_since = time.monotonic()
                self.last_error = f'CAN controller of {self._inner.channel_info} reports bus state ERROR (bus-off)'
            failing_since = self._failing_since
            return BusHealth(bool(failing_since), self.recv_errors, self.send_errors, self.error_frames,
                             self.last_error, self._last_ok, failing_since)

    # -- frames -----------------------------------------------------------------------------
    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        # stamped when handed to the interface, not when its send returns: a send may wait for the
        # bus (or, on the local transport, for a slow receiver) while the frame's answer is already
        # received and stamped; a recording must keep a request before its answer
        handed = time.time()
        try:
            self._inner.send(msg, timeout)
        except BUS_ERRORS as exc:
            self.send_errors += 1
            self._fault('send', exc)
            raise
        self._ok()
        sent = can.Message(
            timestamp=handed, arbitration_id=msg.arbitration_id,
            is_extended_id=msg.is_extended_id, is_remote_frame=msg.is_remote_frame,
            is_error_frame=msg.is_error_frame, dlc=msg.dlc, data=bytes(msg.data),
            is_rx=False, channel=msg.channel,
        )
        self._tap(sent)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        try:
            msg = self._inner.recv(timeout)
        except BUS_ERRORS as exc:  # never let it end the Notifier
            self.recv_errors += 1
            self._fault('receive', exc)
            time.sleep(RECV_ERROR_BACKOFF if timeout is None else min(timeout, RECV_ERROR_BACKOFF))
            return None
        if msg is None:
            return None
        msg.is_rx = True
        self._tap(msg)
        if msg.is_error_frame:  # the controller's report, not CANopen data
            self.error_frames += 1
            self._fault('bus (error frame)', can.CanError(f'error frame 0x{msg.arbitration_id:X} '
                                                          f'data {bytes(msg.data).hex()}'))
            return None
        self._ok()
        return msg

    def _send_periodic_internal(self, msgs: Sequence[can.Message] | can.Message, period: float,
                                duration: float | None = None, autostart: bool = True,
                                modifier_callback: Callable[[can.Message], None] | None = None,
                                ) -> CyclicSendTaskABC:
        """A periodic task that survives failed sends (counted by send()): the master's
        heartbeat must come back by itself when the bus does."""
        return ThreadBasedCyclicSendTask(_QuietSender(self), threading.Lock(), msgs, period, duration,  # type: ignore[arg-type]
                                         on_error=lambda _exc: True, autostart=autostart,
                                         modifier_callback=modifier_callback)

    def send_periodic_by_interface(self, msg: can.Message, period: float) -> CyclicSendTaskABC:
        """The inner interface's own periodic task (SocketCAN: the kernel's BCM timer), for
        ``sync_producer: kernel``. Its frames do not pass send() and so not the tap's send
        path; SocketCAN loops them back to the RAW socket, so they arrive through recv() as
        received frames (``is_rx=True``) and are tapped, counted and recorded there."""
        return self._inner.send_periodic(msg, period)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        return self._inner.recv(timeout), True  # not used: recv is delegated whole

    @property  # type: ignore[misc]  # read-only here: the state is the inner bus's
    def state(self) -> can.BusState:
        """The controller's state; ERROR too while receive or send keep failing."""
        state = self._inner.state
        return can.BusState.ERROR if self._failing_since else state

    @property
    def protocol(self) -> can.CanProtocol:
        return self._inner.protocol

    def fileno(self) -> int:
        return self._inner.fileno()

    def shutdown(self) -> None:
        if self._is_shutdown:
            return
        self._is_shutdown = True
        self._inner.shutdown()


class _QuietSender:
    """send() of a tapped bus with the failure swallowed (it is counted and reported already)."""

    def __init__(self, bus: TappedBus) -> None:
        self._bus = bus

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        try:
            self._bus.send(msg, timeout)
        except BUS_ERRORS:
            pass


def open_bus(interface: str, channel: Any, bitrate: int | None = None,
             **options: Any) -> can.BusABC:
    """Open a python-can bus; errors name the interface and channel."""
    kwargs = dict(options)
    if bitrate:
        kwargs['bitrate'] = bitrate
    plugin = INTERFACES.get(interface)  # the package's own transports, without the entry point too
    try:
        if plugin is not None:
            return plugin(channel=channel, **kwargs)
        return can.Bus(interface=interface, channel=channel, **kwargs)
    except Exception as exc:
        raise can.CanError(f'cannot open CAN bus interface={interface!r} channel={channel!r}: {exc}') from exc
