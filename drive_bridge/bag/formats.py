"""Which kind of recording a file is, by its content (a pasted log saved as ``.txt``, a trace
renamed): the magic bytes of binary formats, then the shape of the first text lines.
``--format`` names one of ``FORMATS`` and skips the guess."""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from drive_bridge.bag.candump import looks_like
from drive_bridge.bag.errors import BagError

# name -> what it is (the name a Recording reports; --format takes the same names)
FORMATS: Mapping[str, str] = {
    'rosbag2-mcap': 'rosbag2 bag (directory with metadata.yaml, or one .mcap file)',
    'candump': 'candump -L log: (1699584944.440580) can0 701#00',
    'candump-screen': 'candump screen output as pasted: "  can0  589   [8]  43 6C 60 00 ..." (-t, -x too)',
    'trc': 'PEAK PCAN-View / PCAN-Explorer trace (.trc, versions 1.0-2.1)',
    'asc': 'Vector ASCII trace (.asc)',
    'blf': 'Vector binary logging format (.blf)',
    'csv': "python-can CSV (timestamp,arbitration_id,extended,remote,error,dlc,data)",
    'sqlite': 'python-can SQLite log (.db)',
    'mf4': 'ASAM MDF 4 (.mf4, needs asammdf)',
    'ixxat-minimon': 'IXXAT MiniMon V3 ASCII trace',
}
SUFFIXES: Mapping[str, str] = {'.trc': 'trc', '.asc': 'asc', '.blf': 'blf', '.log': 'candump', '.csv': 'csv',
                               '.db': 'sqlite', '.mf4': 'mf4', '.mcap': 'rosbag2-mcap'}
_MAGIC = ((b'\x89MCAP', 'rosbag2-mcap'), (b'LOGG', 'blf'), (b'SQLite format 3', 'sqlite'), (b'MDF ', 'mf4'),
          (b'ASCII Trace IXXAT MiniMon', 'ixxat-minimon'))
HEAD_BYTES = 16384


def _text_format(lines: list[str]) -> str | None:
    stripped = [line.strip() for line in lines if line.strip()]
    if any(line.startswith(';$FILEVERSION') for line in stripped[:5]) or \
            (stripped and stripped[0].startswith(';') and any('Message Number' in line for line in stripped[:30])):
        return 'trc'
    lowered = [line.lower() for line in stripped[:10]]
    if any(line.startswith('date ') for line in lowered) and any(line.startswith('base ') for line in lowered):
        return 'asc'
    if stripped and stripped[0].replace(' ', '').lower().startswith('timestamp,arbitration_id'):
        return 'csv'
    return looks_like(lines)


def detect(path: Path) -> str:
    """The format of ``path`` by content, else by suffix; BagError when neither says."""
    if path.is_dir():
        return 'rosbag2-mcap'
    try:
        with path.open('rb') as stream:
            head = stream.read(HEAD_BYTES)
    except OSError as exc:
        raise BagError(f'{path}: cannot read: {exc.strerror or exc}') from exc
    for magic, name in _MAGIC:
        if head.startswith(magic):
            return name
    if b'\0' not in head:
        lines = head.decode('latin-1').splitlines()[:200]
        found = _text_format(lines)
        if found is not None:
            return found
    by_suffix = SUFFIXES.get(path.suffix.lower())
    if by_suffix is not None and (b'\0' in head or not head.strip()):
        return by_suffix
    known = ', '.join(FORMATS)
    raise BagError(f'{path}: unknown format {path.suffix!r}: its content is no recording this tool reads '
                   f'(give --format, one of: {known})')


def check_format(name: str) -> str:
    if name not in FORMATS:
        raise BagError(f'--format {name!r}: not one of {", ".join(FORMATS)}')
    return name
