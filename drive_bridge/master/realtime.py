"""SCHED_FIFO for the threads that keep the cycle's timing (``master.realtime_priority``).

On a machine whose cores are shared (drives simulated next to the bridge, a planner, a
subscriber), the cycle thread that wakes for a SYNC deadline waits for a core behind
ordinary threads; a wait of half a period skips the SYNC. With SCHED_FIFO the kernel runs it
as soon as it wakes (measured in README "Performance": skipped SYNCs at 4 axes/2 ms fell
from about 3 % to 0.3 %). The CAN receive thread gets it too, so the drives' TPDOs that the
cycle waits for are read at once. It is what ros2_control does for its control loop; it
needs CAP_SYS_NICE or an rtprio limit (``/etc/security/limits.conf``), else the threads run
at normal priority and the master says so once.
"""
from __future__ import annotations

import os
import threading
from collections.abc import Callable

import can


def make_realtime(priority: int) -> str | None:
    """Give the calling thread SCHED_FIFO at ``priority`` (1..99); None, or why it could not."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except AttributeError:
        return 'this system has no SCHED_FIFO'
    except OSError as exc:
        hint = (': give the user an rtprio limit (/etc/security/limits.conf) or CAP_SYS_NICE'
                if exc.errno == 1 else '')
        return f'{exc.strerror or exc}{hint}'
    return None


def thread_policy(native_id: int) -> int:
    """The scheduling policy of a thread (os.SCHED_OTHER, os.SCHED_FIFO, ...)."""
    return os.sched_getscheduler(native_id)


class RealtimeReceive(can.Listener):
    """A frame-tap listener that makes the thread delivering frames SCHED_FIFO, once per
    thread: the receive thread is python-can's Notifier's, started again when the bus is
    reopened, so it is found by the frames it delivers rather than by its object."""

    def __init__(self, priority: int, on_failure: Callable[[str], None]) -> None:
        self.priority = priority
        self._on_failure = on_failure
        self._done: set[int] = set()
        self.failed = False

    def on_message_received(self, msg: can.Message) -> None:
        if not msg.is_rx:  # frames sent are tapped in the sending thread (cycle, SDO workers)
            return
        ident = threading.get_ident()
        if ident in self._done:
            return
        self._done.add(ident)
        problem = make_realtime(self.priority)
        if problem is not None and not self.failed:
            self.failed = True
            self._on_failure(problem)
