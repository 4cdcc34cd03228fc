"""Each family's EDS generator (``python -m drive_bridge.families.<family>.edsgen``) writes
exactly the EDS the family ships: a change to a generator or to the skeleton
(families/edswriter.py) that is not run shows up here."""
from __future__ import annotations

import importlib
from pathlib import Path

import pytest

from drive_bridge.families.edswriter import build, write_eds

GENERATORS = ['akd', 'generic402', 'opendrive', 'servostar']


@pytest.mark.parametrize('family', GENERATORS)
def test_the_generator_writes_the_shipped_eds(family: str, tmp_path: Path) -> None:
    files = importlib.import_module(f'drive_bridge.families.{family}.edsgen').FILES
    assert files
    for eds in files:
        assert eds.path.parent.name == 'data' and eds.path.parent.parent.name == family
        written = tmp_path / eds.path.name
        eds.check(write_eds(build(eds.device, eds.sections), written))
        assert written.read_bytes() == eds.path.read_bytes(), \
            f'run .venv/bin/python -m drive_bridge.families.{family}.edsgen'
