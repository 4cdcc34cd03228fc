"""Reader for IXXAT MiniMon V3 ASCII traces, which python-can cannot read.

The format (semicolon CSV with quoted fields after a short header)::

    ASCII Trace IXXAT MiniMon V3  Version: 1.0.0.1271
    Date: 28.01.2025
    ...
    "Time";"Identifier (hex)";"Format";"Flags";"Data (hex)"
    "00:02:20.66";"83";"Std";"";"00 00 00 01 20 00 00 00 "
    "00:02:30.72";"702";"Std";"Rtr ";"Remote request  DLC = 1 "

Time is hh:mm:ss.cc since the trace started (10 ms resolution); the trace has no direction,
so every frame is ``is_rx=True``.
"""
from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import can

from drive_bridge.bag.errors import BagError

MAGIC = 'ASCII Trace IXXAT MiniMon'
COLUMNS = '"Time";"Identifier (hex)";"Format";"Flags";"Data (hex)"'
_RTR_DLC = re.compile(r'Remote request\s+DLC\s*=\s*(\d+)')


def is_minimon(path: Path) -> bool:
    """Whether the file starts like a MiniMon ASCII trace."""
    try:
        with path.open('rb') as stream:
            return stream.read(len(MAGIC)).decode('latin-1') == MAGIC
    except OSError:
        return False


def _time(text: str) -> float:
    hours, minutes, seconds = text.split(':')
    return int(hours) * 3600 + int(minutes) * 60 + float(seconds)


def parse_line(line: str, channel: str = '') -> can.Message:
    """One frame line; ValueError says which field is wrong."""
    fields = [f.strip('"') for f in line.rstrip('\r\n').split(';')]
    if len(fields) != 5:
        raise ValueError(f'expected 5 ";"-separated fields, found {len(fields)}')
    time_text, ident, fmt, flags, data_text = fields
    try:
        timestamp = _time(time_text)
    except ValueError:
        raise ValueError(f'time {time_text!r} is not hh:mm:ss.cc') from None
    try:
        arbitration_id = int(ident, 16)
    except ValueError:
        raise ValueError(f'identifier {ident!r} is not hex') from None
    if fmt not in ('Std', 'Ext'):
        raise ValueError(f'format {fmt!r} is neither Std nor Ext')
    remote = 'rtr' in flags.lower()
    if remote:
        match = _RTR_DLC.search(data_text)
        if not match:
            raise ValueError(f'remote frame without "DLC = n": {data_text!r}')
        data, dlc = b'', int(match.group(1))
    else:
        try:
            data = bytes.fromhex(data_text)
        except ValueError:
            raise ValueError(f'data {data_text!r} is not hex bytes') from None
        dlc = len(data)
    if dlc > 8 or arbitration_id >= (1 << (29 if fmt == 'Ext' else 11)):
        raise ValueError(f'identifier 0x{arbitration_id:X} or DLC {dlc} out of range for {fmt}')
    return can.Message(timestamp=timestamp, arbitration_id=arbitration_id, is_extended_id=fmt == 'Ext',
                       is_remote_frame=remote, is_error_frame='err' in flags.lower(), dlc=dlc, data=data,
                       is_rx=True, channel=channel)


def read_minimon(path: Path) -> Iterator[can.Message]:
    """The frames of a MiniMon trace; BagError naming the line for anything malformed."""
    with path.open('r', encoding='latin-1', newline='') as stream:
        if not stream.readline().startswith(MAGIC):
            raise BagError(f'{path}: not an IXXAT MiniMon trace (first line)')
        header_lines = 1
        for line in stream:
            header_lines += 1
            if line.startswith(COLUMNS):
                break
        else:
            raise BagError(f'{path}: truncated: no column header line {COLUMNS}')
        for number, line in enumerate(stream, start=header_lines + 1):
            if not line.strip():
                continue
            try:
                yield parse_line(line)
            except ValueError as exc:
                raise BagError(f'{path}: line {number}: {exc}') from None
