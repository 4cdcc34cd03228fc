"""Temporary stand-in for bag-record's ``open_recording`` (python-can trace formats only).

Same signature as the shared interface (docs: bag-interface); replaced by bag-record's version
(rosbag2 MCAP and the IXXAT MiniMon trace) when that branch is merged.
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import can

from drive_bridge.bag.errors import BagError

_FORMATS = {'.trc': 'trc', '.asc': 'asc', '.blf': 'blf', '.log': 'candump', '.csv': 'csv'}


@dataclass(frozen=True)
class Recording:
    """What a bag or a trace holds for decoding: its frames and the files stored with it."""

    path: Path
    format: str
    config_yaml: str | None = None
    files: Mapping[str, bytes] = field(default_factory=dict)

    def frames(self) -> Iterator[can.Message]:
        try:
            yield from can.LogReader(str(self.path))
        except (ValueError, IndexError) as exc:
            raise BagError(f'{self.path}: not a readable {self.format} trace: {exc}') from exc


def open_recording(path: Path) -> Recording:
    """A trace python-can reads; BagError naming the file and what is wrong."""
    path = Path(path)
    if not path.exists():
        raise BagError(f'{path}: no such file')
    fmt = _FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise BagError(f'{path}: unknown trace format {path.suffix!r} (known: {", ".join(sorted(_FORMATS))})')
    return Recording(path, fmt)
