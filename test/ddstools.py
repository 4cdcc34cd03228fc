"""Stale Fast DDS shared memory: what processes the tests kill leave in /dev/shm (no rclpy here)."""
from __future__ import annotations

import os
from pathlib import Path

SHM = Path('/dev/shm')


def remove_stale_dds_segments() -> int:
    """Delete Fast DDS shared-memory files (``/dev/shm/fastrtps_*``, ``sem.fastrtps_*``) that no
    live process maps or holds open: what killed processes left. Returns how many were removed."""
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
    for path in SHM.iterdir():
        if path.name.startswith(('fastrtps_', 'sem.fastrtps_')) and str(path) not in mapped:
            try:
                path.unlink()
                removed += 1
            except OSError:
                pass
    return removed
