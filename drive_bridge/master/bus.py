"""Opening the CAN bus, with a tap that sees every frame in both directions.

python-can has no hook for sent frames, so the bridge's bus is a thin proxy
(:class:`TappedBus`) in front of the real interface: every ``send`` and every
``recv`` is reported to the tap's listeners. canopen's Network is built on the proxy,
so SDO, NMT, SYNC and PDO traffic all pass through it.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import can

from drive_bridge.transport import INTERFACES

FrameListener = Callable[[can.Message], None]


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
            self._listeners = [x for x in self._listeners if x is not listener]

    def __call__(self, msg: can.Message) -> None:
        for listener in self._listeners:
            try:
                listener(msg)
            except Exception as exc:  # a broken consumer must not break the bus
                if len(self.errors) < 100:
                    self.errors.append(f'{listener!r}: {exc!r}')


class TappedBus(can.BusABC):
    """A bus proxy that reports sent (``is_rx=False``) and received frames to a tap."""

    def __init__(self, inner: can.BusABC, tap: FrameTap) -> None:
        self._inner = inner
        self._tap = tap
        super().__init__(channel=getattr(inner, 'channel', None) or '')  # no filters: the inner bus filters
        self.channel_info = f'tapped {inner.channel_info}'

    # periodic sends (e.g. the master heartbeat) use BusABC's thread task, which calls
    # send() and so passes the tap

    @property
    def inner(self) -> can.BusABC:
        return self._inner

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self._inner.send(msg, timeout)
        sent = can.Message(
            timestamp=time.time(), arbitration_id=msg.arbitration_id,
            is_extended_id=msg.is_extended_id, is_remote_frame=msg.is_remote_frame,
            is_error_frame=msg.is_error_frame, dlc=msg.dlc, data=bytes(msg.data),
            is_rx=False, channel=msg.channel,
        )
        self._tap(sent)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        msg = self._inner.recv(timeout)
        if msg is not None:
            msg.is_rx = True
            self._tap(msg)
        return msg

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        return self._inner.recv(timeout), True  # not used: recv is delegated whole

    @property  # type: ignore[misc]  # read-only here: the state is the inner bus's
    def state(self) -> can.BusState:
        return self._inner.state

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
