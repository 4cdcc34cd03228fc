"""Which of the integrator's EDS/DCF files describes a node a scan found, by its identity.

A starter bus config must name the file the bridge is to use (``dcf``): without one, a drive
that no family knows by product would run on the generic CiA 402 EDS. A file's identity is
its [DeviceInfo] (VendorNumber, ProductNumber, RevisionNumber), else the defaults of 0x1018;
a node matches a file with the same vendor id and product code, the same revision first.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from canopen import ObjectDictionary

from drive_bridge.bag.errors import BagError
from drive_bridge.config.eds import SUFFIXES, read_object_dictionary
from drive_bridge.config.errors import EdsError
from drive_bridge.model import Identity

IDENTITY = 0x1018


@dataclass(frozen=True)
class EdsFile:
    """One EDS/DCF and the identity it describes (0: not given)."""

    path: Path
    vendor_id: int
    product_code: int
    revision_number: int


def eds_paths(given: Iterable[Path]) -> list[Path]:
    """The files given, and the EDS/DCF files in the directories given (sorted by name)."""
    paths: list[Path] = []
    for path in given:
        if path.is_dir():
            paths += sorted(p for p in path.iterdir() if p.suffix.lower() in SUFFIXES and p.is_file())
        elif path.is_file():
            paths.append(path)
        else:
            raise BagError(f'--eds {path}: no such file or directory')
    return paths


def _default(od: ObjectDictionary, sub: int) -> int:
    record = od.get(IDENTITY)
    var = record.subindices.get(sub) if record is not None and hasattr(record, 'subindices') else None
    value = var.default if var is not None else None
    return value if isinstance(value, int) else 0


def read_eds_files(paths: Sequence[Path]) -> tuple[list[EdsFile], list[str]]:
    """The identity of each file, and a note for each file that cannot be read (skipped)."""
    files, notes = [], []
    for path in paths:
        try:
            od, _ = read_object_dictionary(path, None)
        except EdsError as exc:
            notes.append(f'{path}: skipped: {exc}')
            continue
        info = od.device_information
        files.append(EdsFile(path, int(info.vendor_number or 0) or _default(od, 1),
                             int(info.product_number or 0) or _default(od, 2),
                             int(info.revision_number or 0) or _default(od, 3)))
    return files, notes


def matching(identity: Identity, files: Sequence[EdsFile]) -> list[EdsFile]:
    """The files describing a node of this identity: vendor id and product code equal (both
    known and not 0), those of its revision first."""
    if not identity.vendor_id or not identity.product_code:
        return []
    same = [f for f in files if (f.vendor_id, f.product_code) == (identity.vendor_id, identity.product_code)]
    return sorted(same, key=lambda f: f.revision_number != identity.revision_number)
