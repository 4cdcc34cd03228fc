"""SCHED_FIFO for the cycle thread (``master.realtime_priority``).

On a machine whose cores are shared (drives simulated next to the bridge, a planner, a
subscriber), the cycle thread that wakes for a SYNC deadline waits for a core behind
ordinary threads; a wait of half a period skips the SYNC. With SCHED_FIFO the kernel runs it
as soon as it wakes, and a GIL switch interval of 0.5 ms (instead of 5 ms) bounds how long
another thread of the process may keep the interpreter once the cycle thread asks for it
(measured in docs/performance.md). The CAN receive thread is left at normal priority: made
SCHED_FIFO too it cost 10 points of CPU and 0.3 ms of `/joint_states` latency, and skipped
no fewer SYNCs. It is what ros2_control does for its control loop; it needs CAP_SYS_NICE or
an rtprio limit (``/etc/security/limits.conf``), else the cycle runs at normal priority and
the master says so once.
"""
from __future__ import annotations

import os
import sys
import threading

SWITCH_INTERVAL = 0.0005  # s: the GIL switch interval while a real-time cycle runs


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


class SwitchInterval:
    """Lowers the interpreter's GIL switch interval while a real-time cycle runs, and puts back
    what it found. It is the whole process's setting, so the masters of one process share it:
    lowered by the first that asks, given back when the last of them lets go."""

    _lock = threading.Lock()
    _holders = 0
    _previous = 0.0

    def __init__(self) -> None:
        self._held = False

    def lower(self) -> None:
        with SwitchInterval._lock:
            if self._held:
                return
            self._held = True
            if SwitchInterval._holders == 0:
                SwitchInterval._previous = sys.getswitchinterval()
                sys.setswitchinterval(min(SwitchInterval._previous, SWITCH_INTERVAL))
            SwitchInterval._holders += 1

    def restore(self) -> None:
        with SwitchInterval._lock:
            if not self._held:
                return
            self._held = False
            SwitchInterval._holders -= 1
            if SwitchInterval._holders == 0:
                sys.setswitchinterval(SwitchInterval._previous)
