"""The test session's ROS domain (``ddstools.claim_domain``): two sessions on one machine never
share one, so one suite's bridge cannot publish into another's topics."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from ddstools import claim_domain

TEST = Path(__file__).parent


def test_a_domain_held_by_one_session_is_not_given_to_another() -> None:
    held = claim_domain()  # held by this process until it ends
    code = 'from ddstools import claim_domain; print(claim_domain())'
    other = subprocess.run([sys.executable, '-c', code], cwd=TEST, capture_output=True, text=True, check=True,
                           timeout=30)
    assert 1 <= int(other.stdout) <= 100 and int(other.stdout) != held
    assert claim_domain() != held  # nor to this process again
