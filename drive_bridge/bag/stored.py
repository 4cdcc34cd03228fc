"""The bus config a bag stores, loaded again: its EDS/DCF files are put in a temporary
directory where the config's relative paths (``../../shared/x.dcf`` too) find them, and
nothing a bag names is ever written outside that directory."""
from __future__ import annotations

import tempfile
from collections.abc import Mapping
from pathlib import Path, PurePosixPath

from drive_bridge.config.loader import load_bus_config_text
from drive_bridge.model import BusConfig


def materialise(files: Mapping[str, bytes], tmp: str | Path) -> Path:
    """Write ``files`` (keys relative to the config's directory) under ``tmp``; returns the
    directory that stands for the config's one: deep enough in ``tmp`` that every ``..`` of a
    key stays inside. An absolute key, or one that escapes anyway, is skipped."""
    ups = max((PurePosixPath(name).parts.count('..') for name in files), default=0)
    root = Path(tmp).resolve()
    base = Path(root, *['c'] * ups)
    base.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        if PurePosixPath(name).is_absolute():
            continue
        target = (base / name).resolve()
        if not target.is_relative_to(root) or target == root:
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
    return base


def load_stored_config(text: str, files: Mapping[str, bytes], source: str) -> BusConfig:
    """The bus config stored in a bag (the object dictionaries are loaded now: the files may go)."""
    with tempfile.TemporaryDirectory(prefix='drive_bridge_stored_') as tmp:
        return load_bus_config_text(text, source, materialise(files, tmp))
