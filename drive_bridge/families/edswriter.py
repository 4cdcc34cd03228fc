"""Building object dictionaries in code and writing them as EDS files: the skeleton of the
families' EDS generators (``python -m drive_bridge.families.<family>.edsgen``), which only
describe their objects. Works around two gaps of canopen 2.4.1's exporter: node-id relative
values (``$NODEID+...``) and negative defaults."""
from __future__ import annotations

import io
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import canopen
from canopen.objectdictionary import ODArray, ODRecord, ODVariable, datatypes as dt

VOLATILE_KEYS = ('CreationDate', 'CreationTime', 'ModificationDate', 'ModificationTime')

Section = Callable[[canopen.ObjectDictionary], None]  # adds one area's objects
Check = Callable[[canopen.ObjectDictionary], None]  # asserts what the file read back must hold


@dataclass(frozen=True)
class Device:
    """The [DeviceInfo] of a generated EDS."""

    vendor_name: str
    vendor_number: int
    product_name: str
    product_number: int
    revision: int
    baud_kbit: tuple[int, ...]
    simple_boot_up_slave: bool = True


@dataclass(frozen=True)
class EdsFile:
    """One shipped EDS: where it goes, its device, the sections that add its objects (in
    order), and the checks on the file as canopen reads it back."""

    path: Path
    device: Device
    sections: tuple[Section, ...]
    check: Check


def new_od(device: Device) -> canopen.ObjectDictionary:
    """An empty dictionary with its [DeviceInfo]: 4 RPDOs and 4 TPDOs, byte granularity."""
    od = canopen.ObjectDictionary()
    info = od.device_information
    info.vendor_name, info.vendor_number = device.vendor_name, device.vendor_number
    info.product_name, info.product_number = device.product_name, device.product_number
    info.revision_number = device.revision
    info.nr_of_RXPDO = info.nr_of_TXPDO = 4
    info.simple_boot_up_slave = device.simple_boot_up_slave
    info.granularity = 8  # mappings in whole bytes
    for rate in device.baud_kbit:
        info.allowed_baudrates.add(rate * 1000)
    return od


def var(name: str, index: int, sub: int, data_type: int, access: str = 'rw', default: int | str | None = 0,
        mappable: bool = False, relative: bool = False, low: int | None = None,
        high: int | None = None) -> ODVariable:
    """One variable; ``relative`` makes its default node-id relative (COB-IDs)."""
    v = ODVariable(name, index, sub)
    v.data_type, v.access_type, v.pdo_mappable, v.relative = data_type, access, mappable, relative
    v.default = default  # type: ignore[assignment]  # canopen annotates int; strings are defaults too
    if relative:  # the exporter writes default_raw (read with getattr) verbatim: keep $NODEID in the file
        v.default_raw = f'$NODEID+0x{default:X}'  # type: ignore[attr-defined]
    elif isinstance(default, int) and default < 0:  # canopen 2.4.1 exports negatives as '0x-3'
        v.default_raw = str(default)  # type: ignore[attr-defined]
    if data_type == dt.VISIBLE_STRING:
        v.default = default or ''  # type: ignore[assignment]
    v.min, v.max = low, high
    return v


def container(name: str, index: int, members: list[ODVariable], array: bool = False,
              count_access: str = 'ro', count: int | None = None) -> ODRecord | ODArray:
    """A record (or array) with its sub-index 0 'highest sub-index supported'."""
    box = ODArray(name, index) if array else ODRecord(name, index)
    box.add_member(var('Highest sub-index supported', index, 0, dt.UNSIGNED8, count_access,
                       len(members) if count is None else count))
    for member in members:
        box.add_member(member)
    return box


def mapping_record(name: str, index: int, entries: Sequence[int] = ()) -> ODRecord:
    """A PDO mapping parameter: eight entries, ``entries`` first, sub 0 (rw) the count in use."""
    members = [var(f'Mapping entry {i}', index, i, dt.UNSIGNED32, 'rw', entries[i - 1] if i <= len(entries) else 0)
               for i in range(1, 9)]
    record = container(name, index, members, count_access='rw', count=len(entries))
    assert isinstance(record, ODRecord)
    return record


def write_eds(od: canopen.ObjectDictionary, path: Path) -> canopen.ObjectDictionary:
    """Write ``od`` as an EDS without the volatile date lines (stable files in git), and
    return it read back (node id 5) for the caller's checks."""
    text = io.StringIO()
    canopen.export_od(od, text, doc_type='eds')
    lines = [line for line in text.getvalue().splitlines() if not line.startswith(VOLATILE_KEYS)]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text('\n'.join(lines) + '\n')
    return canopen.import_od(str(path), node_id=5)


def variable(od: canopen.ObjectDictionary, index: int, sub: int = 0) -> ODVariable:
    """A variable of a dictionary read back, for a generator's checks (sub 0 of a VAR is itself)."""
    entry = od[index]
    found = entry if isinstance(entry, ODVariable) and sub == 0 else members(od, index)[sub]
    assert isinstance(found, ODVariable), f'0x{index:04X}:{sub:02X} is not a variable'
    return found


def members(od: canopen.ObjectDictionary, index: int) -> ODRecord | ODArray:
    """A record or array of a dictionary read back, for a generator's checks."""
    entry = od[index]
    assert isinstance(entry, (ODRecord, ODArray)), f'0x{index:04X} is not a record or array'
    return entry


def build(device: Device, sections: Sequence[Section]) -> canopen.ObjectDictionary:
    """The dictionary of ``device`` with every section's objects, in order."""
    od = new_od(device)
    for add in sections:
        add(od)
    return od


def main(files: Sequence[EdsFile]) -> None:
    """Write each file, check it as read back, and say so: a generator's ``__main__``."""
    for eds in files:
        reread = write_eds(build(eds.device, eds.sections), eds.path)
        eds.check(reread)
        print(f'wrote {eds.path} ({len(reread)} objects)')
