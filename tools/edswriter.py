"""Building object dictionaries in code and writing them as EDS files, for the drive
families' shipped EDS (tools/make_*_eds.py). Works around two gaps of canopen 2.4.1's
exporter: node-id relative values (``$NODEID+...``) and negative defaults."""
from __future__ import annotations

import io
from pathlib import Path

import canopen
from canopen.objectdictionary import ODArray, ODRecord, ODVariable, datatypes as dt

VOLATILE_KEYS = ('CreationDate', 'CreationTime', 'ModificationDate', 'ModificationTime')


def new_od(vendor_name: str, vendor_number: int, product_name: str, product_number: int, revision: int,
           baud_kbit: tuple[int, ...], simple_boot_up_slave: bool = True) -> canopen.ObjectDictionary:
    """An empty dictionary with its [DeviceInfo]: 4 RPDOs and 4 TPDOs, byte granularity."""
    od = canopen.ObjectDictionary()
    info = od.device_information
    info.vendor_name, info.vendor_number = vendor_name, vendor_number
    info.product_name, info.product_number, info.revision_number = product_name, product_number, revision
    info.nr_of_RXPDO = info.nr_of_TXPDO = 4
    info.simple_boot_up_slave = simple_boot_up_slave
    info.granularity = 8  # mappings in whole bytes
    for rate in baud_kbit:
        info.allowed_baudrates.add(rate * 1000)
    return od


def var(name: str, index: int, sub: int, data_type: int, access: str = 'rw', default=0,
        mappable: bool = False, relative: bool = False, low: int | None = None,
        high: int | None = None) -> ODVariable:
    """One variable; ``relative`` makes its default node-id relative (COB-IDs)."""
    v = ODVariable(name, index, sub)
    v.data_type, v.access_type, v.default, v.pdo_mappable, v.relative = data_type, access, default, mappable, relative
    if relative:  # the exporter writes default_raw verbatim: keep $NODEID in the file
        v.default_raw = f'$NODEID+0x{default:X}'
    elif isinstance(default, int) and default < 0:  # canopen 2.4.1 exports negatives as '0x-3'
        v.default_raw = str(default)
    if data_type == dt.VISIBLE_STRING:
        v.default = default or ''
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


def write_eds(od: canopen.ObjectDictionary, path: Path) -> canopen.ObjectDictionary:
    """Write ``od`` as an EDS without the volatile date lines (stable files in git), and
    return it read back (node id 5) for the caller's checks."""
    text = io.StringIO()
    canopen.export_od(od, text, doc_type='eds')
    lines = [line for line in text.getvalue().splitlines() if not line.startswith(VOLATILE_KEYS)]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text('\n'.join(lines) + '\n')
    return canopen.import_od(str(path), node_id=5)
