"""Starting a process as a non-interactive shell starts a background job: SIGINT (and SIGQUIT)
ignored, stdin not a terminal. Through the shell itself (``trap '' INT`` then ``exec``): an
ignored disposition survives exec; a ``preexec_fn`` would run Python in the forked child of a
process with threads (the test process has ROS executors and simulators running), which can
deadlock before exec."""
from __future__ import annotations

from collections.abc import Sequence


def from_background_shell(argv: Sequence[str]) -> list[str]:
    """``argv`` wrapped so that it starts with SIGINT and SIGQUIT ignored and stdin on /dev/null."""
    return ['bash', '-c', 'trap "" INT QUIT; exec "$@" < /dev/null', 'bash', *map(str, argv)]
