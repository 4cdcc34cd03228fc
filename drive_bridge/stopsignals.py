"""Stopping on SIGINT and SIGTERM whatever disposition the process inherited.

A process started in the background by a non-interactive shell (``cmd &`` in a script, a CI
runner, some service managers) inherits SIGINT as *ignored*, and Python then installs no
KeyboardInterrupt handler: Ctrl-C and ``kill -INT`` were dropped and ``drive-bridge record``
recorded for ever. Every entry point that runs until it is stopped installs its own handlers
with :func:`stop_on_signals`, so SIGINT and SIGTERM stop it the same way from a terminal, a
script, a test or systemd.

Two ways to stop, chosen by the caller:

- a loop that polls (record, sim) reads :attr:`StopRequest.requested` (or waits on it) and
  ends at its next turn, so its clean-up runs from ordinary code;
- work that is one long call (import, replay, scan, diagnose, the ROS executor's spin) passes
  ``interrupt=True``: the signal raises :class:`StopSignal` (a KeyboardInterrupt) in the main
  thread, as Ctrl-C does in a terminal, and the work's ``finally`` / ``except BaseException``
  clean-up runs.

A second signal while a polling loop winds down raises :class:`StopSignal` too: the user
insists. The previous handlers are put back when the block ends. Python runs signal handlers
in the main thread only, so outside it (a verb called from a test's thread) nothing is
installed and the block only yields a request nobody sets.

Exit codes: a verb stopped by a signal in the middle of its work exits ``128 + signal``
(130 for SIGINT, 143 for SIGTERM, as a shell reports a killed command); a verb for which the
signal is the normal end (``record``, ``sim``, the ``bridge``) exits 0 after a clean stop.
"""
from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopSignal(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived: raised in the main thread (``signum`` says which)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def exit_code(interrupt: BaseException) -> int:
    """The exit code of a process ended by ``interrupt`` (a StopSignal or a plain KeyboardInterrupt)."""
    return 128 + getattr(interrupt, 'signum', signal.SIGINT)


class StopRequest:
    """Set by the first stop signal; ``signum`` says which (None until one arrived)."""

    def __init__(self) -> None:
        self.event = threading.Event()
        self.signum: int | None = None

    @property
    def requested(self) -> bool:
        return self.event.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait up to ``timeout`` s for a stop signal; whether one came."""
        return self.event.wait(timeout)

    def _on_signal(self, signum: int, _frame: FrameType | None, interrupt: bool) -> None:
        if self.event.is_set() or interrupt:
            self.signum = self.signum or signum
            self.event.set()
            raise StopSignal(signum)
        self.signum = signum
        self.event.set()


@contextmanager
def stop_on_signals(*, interrupt: bool = False) -> Iterator[StopRequest]:
    """Within the block, SIGINT and SIGTERM set the yielded request (``interrupt``: and raise
    StopSignal in the main thread); the previous handlers are restored after it."""
    request = StopRequest()
    if threading.current_thread() is not threading.main_thread():
        yield request
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        request._on_signal(signum, frame, interrupt)
    previous = {sig: signal.signal(sig, handler) for sig in STOP_SIGNALS}
    try:
        yield request
    finally:
        for sig, old in previous.items():  # None: a handler installed by C code (rclpy), not restorable
            signal.signal(sig, signal.SIG_DFL if old is None else old)
