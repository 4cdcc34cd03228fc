"""Stale Fast DDS shared memory: what processes the tests kill leave in /dev/shm (no rclpy here)."""
from __future__ import annotations

import os
import time
from pathlib import Path

SHM = Path('/dev/shm')
FRESH = 60.0  # s: a younger file may be one a live process (another suite's) is still creating


def remove_stale_dds_segments() -> int:
    """Delete Fast DDS shared-memory files (``/dev/shm/fastrtps_*``, ``sem.fastrtps_*``) that no
    live process maps or holds open, and that are older than ``FRESH`` (a suite beside this one
    may be creating one right now): what killed processes left. Returns how many were removed."""
    if not SHM.is_dir():
        return 0
    mapped: set[str] = set()  # mapped or held open (a lock file) by some live process
    for proc in Path('/proc').glob('[0-9]*'):
        try:
            mapped.update(line.rsplit(' ', 1)[-1].strip() for line in (proc / 'maps').read_text().splitlines()
                          if '/dev/shm/' in line)
            for fd in (proc / 'fd').iterdir():
                target = os.readlink(fd)
                if target.startswith('/dev/shm/'):
                    mapped.add(target)
        except OSError:  # the process ended meanwhile, or is not ours
            continue
    removed = 0
    now = time.time()
    for path in SHM.iterdir():
        if path.name.startswith(('fastrtps_', 'sem.fastrtps_')) and str(path) not in mapped:
            try:
                if now - path.stat().st_mtime < FRESH:  # maybe being created by a live process (another suite)
                    continue
                path.unlink()
                removed += 1
            except OSError:
                pass
    return removed


_claimed: list[object] = []  # the lock files held for the life of this process


def claim_domain(first: int = 1, last: int = 100) -> int:
    """A ROS domain that no other test session on this machine holds: an ``flock`` on
    ``/tmp/drive_bridge-domain-N.lock``, kept while this process lives (the kernel drops it when
    the process ends, however it ends). Two suites (two worktrees, or a suite beside a benchmark
    run the same way) in one domain cross-talk: the other's bridge publishes into our
    ``/joint_states`` and takes our trajectories. Starts at this process id, as before."""
    import fcntl
    count = last - first + 1
    start = os.getpid() % count
    for k in range(count):
        domain = first + (start + k) % count
        lock = open(f'/tmp/drive_bridge-domain-{domain}.lock', 'a')  # noqa: SIM115 (held until exit)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        _claimed.append(lock)
        return domain
    return first + start  # every domain held: share one, as before
