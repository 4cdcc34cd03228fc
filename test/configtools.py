"""Helpers for the configuration tests: fixture paths and loading YAML text from a file
named like a user's (messages then start with 'drives.yaml: ...')."""
from __future__ import annotations

import os
import textwrap
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from drive_bridge.config import ConfigError, load_bus_config
from drive_bridge.model import BusConfig

CONFIGS = Path(__file__).resolve().parent / 'data' / 'configs'
# CI clones the repository with the shared facts beside it (../shared).
REALDATA = Path(__file__).resolve().parents[1] / '..' / 'shared' / 'realdata'
REAL_EDS = REALDATA / 'eds'


@contextmanager
def inside(directory: Path) -> Iterator[None]:
    previous = Path.cwd()
    os.chdir(directory)
    try:
        yield
    finally:
        os.chdir(previous)


def load_yaml(tmp_path: Path, text: str, name: str = 'drives.yaml') -> BusConfig:
    """Write ``text`` to ``tmp_path/name`` and load it by its relative name."""
    (tmp_path / name).write_text(textwrap.dedent(text), encoding='utf-8')
    with inside(tmp_path):
        return load_bus_config(name)


def problems(tmp_path: Path, text: str, name: str = 'drives.yaml') -> list[str]:
    """The lines of the ConfigError that loading ``text`` must raise."""
    with pytest.raises(ConfigError) as caught:
        load_yaml(tmp_path, text, name)
    return str(caught.value).splitlines()
