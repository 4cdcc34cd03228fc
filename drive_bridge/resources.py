"""Finding the files drive_bridge ships (demo and example configurations, the families' data)."""
from __future__ import annotations

import os
import sys
from pathlib import Path

PACKAGE = 'drive_bridge'
FAMILIES_DIR = Path(__file__).resolve().parent / 'families'


def config_dirs() -> list[Path]:
    """Where shipped configs may be: ament share dir, this prefix's share dir, the checkout."""
    dirs = []
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            dirs.append(Path(prefix) / 'share' / PACKAGE / 'config')
    dirs.append(Path(sys.prefix) / 'share' / PACKAGE / 'config')
    dirs.append(Path(__file__).resolve().parent.parent / 'config')  # source checkout (editable)
    return dirs


def shipped_config(name: str) -> Path:
    """Path of a shipped config file; raises FileNotFoundError naming the places searched."""
    for directory in config_dirs():
        candidate = directory / name
        if candidate.is_file():
            return candidate
    searched = ', '.join(str(d) for d in config_dirs())
    raise FileNotFoundError(f'shipped config {name!r} not found in: {searched}')


def family_data(package: str, name: str) -> Path:
    """A file a built-in family ships (EDS, tables): ``families/<package>/data/<name>``, package
    data beside the family's code, so a vendor's files live in one tree."""
    return FAMILIES_DIR / package / 'data' / name
