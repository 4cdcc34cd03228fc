"""The test session's ROS domain (``ddstools.claim_domain``): two sessions on one machine never
share one, so one suite's bridge cannot publish into another's topics. And the clean-up of
stale Fast DDS shared memory leaves alone what a suite beside this one may be creating."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ddstools import FRESH, SHM, claim_domain, remove_stale_dds_segments

TEST = Path(__file__).parent


def test_a_domain_held_by_one_session_is_not_given_to_another() -> None:
    held = claim_domain()  # held by this process until it ends
    code = 'from ddstools import claim_domain; print(claim_domain())'
    other = subprocess.run([sys.executable, '-c', code], cwd=TEST, capture_output=True, text=True, check=True,
                           timeout=30)
    assert 1 <= int(other.stdout) <= 100 and int(other.stdout) != held
    assert claim_domain() != held  # nor to this process again


@pytest.mark.skipif(not SHM.is_dir(), reason='no /dev/shm')
def test_a_fresh_unmapped_segment_is_kept_and_a_stale_one_removed() -> None:
    fresh, stale = (SHM / f'fastrtps_drive_bridge_test_{os.getpid()}_{k}' for k in ('fresh', 'stale'))
    try:
        fresh.write_bytes(b'')  # as a process beside us creates its port before it maps it
        stale.write_bytes(b'')
        old = time.time() - 2 * FRESH
        os.utime(stale, (old, old))
        remove_stale_dds_segments()
        assert fresh.exists() and not stale.exists()
    finally:
        for path in (fresh, stale):
            path.unlink(missing_ok=True)
