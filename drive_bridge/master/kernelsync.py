"""SYNC timed by the kernel (``master.sync_producer: kernel``) instead of the bridge's thread.

On SocketCAN, python-can's ``send_periodic`` hands the frame to the kernel's Broadcast
Manager (BCM): the kernel sends it on its own timer, so a stalled Python process (GIL,
garbage collector, a busy core) does not delay SYNC. The kernel loops frames of the BCM
socket back to the host's other CAN sockets, so the bus's RAW socket receives every SYNC
and the master runs its cycle from the received frame, as with an external producer.

Untested on real SocketCAN: these machines have none. It is exercised only through a test
double that declares the capability (test/test_kernel_sync.py).
"""
from __future__ import annotations

import threading

import can
from can.broadcastmanager import CyclicSendTaskABC

from drive_bridge.config.errors import ConfigError
from drive_bridge.master.bus import TappedBus
from drive_bridge.master.sync import SYNC_COB_ID

CAPABILITY_ATTRIBUTE = 'sends_periodic_in_kernel'


def sends_periodic_in_kernel(bus: can.BusABC | type[can.BusABC]) -> bool:
    """Whether ``bus.send_periodic`` is timed outside Python and its frames come back as
    received frames on ``bus`` itself: the two things ``sync_producer: kernel`` relies on.

    BusABC's default periodic task is a Python thread (after a stall it sends the missed
    frames back to back), and a frame it sends is not received by the same bus; that is no
    better than the bridge's own producer, and the cycle would never see its SYNC. python-can
    marks the kernel's timer by overriding ``_send_periodic_internal``; of the interfaces that
    override it, SocketCAN's is the kernel's BCM, whose frames are looped back to the bus's
    RAW socket (adapters with a cyclic timer in firmware do not echo them). So: the method is
    overridden and the class comes from python-can's socketcan package.

    A bus class may declare the capability instead with a class attribute
    ``sends_periodic_in_kernel = True`` (or ``False`` to refuse it): an interface plugin
    outside python-can with the same behaviour, or a test double. Takes a bus or its class.
    """
    cls = bus if isinstance(bus, type) else type(bus)
    declared = getattr(cls, CAPABILITY_ATTRIBUTE, None)
    if declared is not None:
        return bool(declared)
    overridden = cls._send_periodic_internal is not can.BusABC._send_periodic_internal
    return overridden and cls.__module__.startswith('can.interfaces.socketcan')


def require_kernel_periodic(bus: can.BusABC, interface: str, channel: object, source: str) -> None:
    """Refuse ``sync_producer: kernel`` on a bus without the capability (ConfigError, at start)."""
    if sends_periodic_in_kernel(bus):
        return
    raise ConfigError.single(
        source, 'master.sync_producer',
        f"'kernel' needs an interface whose periodic frames the kernel sends and loops back "
        f"(SocketCAN's broadcast manager); bus interface {interface!r} channel {channel!r} "
        f'({type(bus).__name__}) has no such timer: use sync_producer: bridge')


class KernelSync:
    """The kernel's periodic SYNC task: started at master start, stopped on stop and while
    the bus is down, restarted on the (possibly reopened) interface when it works again."""

    def __init__(self, bus: TappedBus, period: float) -> None:
        self._bus = bus
        self.period = period
        self._task: CyclicSendTaskABC | None = None
        self._lock = threading.Lock()

    @property
    def running(self) -> bool:
        return self._task is not None

    def start(self) -> None:
        with self._lock:
            if self._task is None:
                sync = can.Message(arbitration_id=SYNC_COB_ID, data=b'', is_extended_id=False)
                self._task = self._bus.send_periodic_by_interface(sync, self.period)

    def stop(self) -> None:
        with self._lock:
            task, self._task = self._task, None
        if task is not None:
            try:
                task.stop()
            except (can.CanError, OSError, ValueError):  # a dead interface: its timer is gone with it
                pass
