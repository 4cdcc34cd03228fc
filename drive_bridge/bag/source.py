"""One way to read every recording: rosbag2 bags of this package, python-can traces, MiniMon.

:func:`open_recording` looks at the path once and returns a :class:`Recording` whose
``frames()`` iterates the raw CAN frames in time order, so the diagnosis and replay tools
never care where the frames came from.
"""
from __future__ import annotations

import logging
import struct
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can
from rosbags.highlevel import AnyReader
from rosbags.interfaces import Connection

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.ixxat import is_minimon, read_minimon
from drive_bridge.bag.typestore import typestore
from drive_bridge.bag.writer import CONFIG_TOPIC, FILES_TOPIC, FRAME_HEAD, FRAME_TYPE

# python-can's LogReader formats by file suffix, and the name a Recording reports for each
TRACE_FORMATS: Mapping[str, str] = {
    '.trc': 'trc', '.asc': 'asc', '.blf': 'blf', '.log': 'candump', '.csv': 'csv',
    '.db': 'sqlite', '.mf4': 'mf4',
}
EMPTY_TRACE_BYTES = 1024  # a trace this big with no frame is not a trace of that format
_HEAD = struct.Struct('<iII')


def decode_frame(cdr: bytes | memoryview) -> can.Message:
    """A drive_bridge_interfaces/CanFrame from CDR (little-endian), by hand: fast."""
    buf = memoryview(cdr)[4:]
    sec, nsec, length = _HEAD.unpack_from(buf, 0)
    channel = bytes(buf[12:12 + length - 1]).decode('utf-8')
    offset = 12 + length
    offset += -offset % 4
    ident, ext, rtr, err, dlc, size = FRAME_HEAD.unpack_from(buf, offset)
    offset += FRAME_HEAD.size
    data = bytes(buf[offset:offset + size])
    return can.Message(timestamp=sec + nsec * 1e-9, arbitration_id=ident, is_extended_id=bool(ext),
                       is_remote_frame=bool(rtr), is_error_frame=bool(err), dlc=dlc, data=data,
                       is_rx=buf[offset + size] == 0, channel=channel, check=False)


@dataclass(frozen=True)
class Recording:
    """What a bag or a trace holds for decoding: its frames and the files stored with it."""

    path: Path
    format: str                  # 'rosbag2-mcap', 'trc', 'asc', 'blf', 'candump', 'csv', 'ixxat-minimon', ...
    config_yaml: str | None      # the bus config stored in the bag (None for vendor traces)
    files: Mapping[str, bytes] = field(default_factory=dict)  # EDS/DCF by the name the config uses
    strict: bool = True          # a line python-can's reader skips is a BagError (else noted in skipped)
    skipped: list[str] = field(default_factory=list)  # lines skipped (strict=False), each with the reason

    def frames(self) -> Iterator[can.Message]:
        """Frames in time order (timestamp in s); BagError naming the frame where the input breaks."""
        if self.format == 'rosbag2-mcap':
            yield from _bag_frames(self.path)
        elif self.format == 'ixxat-minimon':
            yield from read_minimon(self.path)
        else:
            yield from _trace_frames(self.path, self.strict, self.skipped)


def open_recording(path: Path, strict: bool = True) -> Recording:
    """A rosbag2 directory or .mcap file, or any trace python-can reads, or an IXXAT MiniMon
    trace; BagError naming the file and what is wrong (missing, unknown format, truncated...)."""
    path = Path(path)
    if not path.exists():
        raise BagError(f'{path}: no such file or directory')
    if path.is_dir() or path.suffix == '.mcap':
        return _open_bag(path)
    if is_minimon(path):
        return Recording(path, 'ixxat-minimon', None, {}, strict)
    fmt = TRACE_FORMATS.get(path.suffix.lower())
    if fmt is None:
        known = ', '.join(sorted(TRACE_FORMATS))
        raise BagError(f'{path}: unknown format {path.suffix!r} (known: rosbag2 directory, .mcap, {known}, '
                       'IXXAT MiniMon ASCII trace)')
    return Recording(path, fmt, None, {}, strict)


def bag_reader(path: Path) -> AnyReader:
    if path.is_dir() and not (path / 'metadata.yaml').exists():
        hint = f' (a split left open? run: drive-bridge recover {path})' if any(path.glob('*.mcap')) else ''
        raise BagError(f'{path}: not a rosbag2 bag: no metadata.yaml{hint}')
    reader = AnyReader([path], default_typestore=typestore())
    try:
        reader.open()
    except Exception as exc:
        raise BagError(f'{path}: unreadable bag (truncated or corrupt? try drive-bridge recover): {exc}') from exc
    return reader


def _open_bag(path: Path) -> Recording:
    reader = bag_reader(path)
    try:
        config: str | None = None
        files: dict[str, bytes] = {}
        stored = [c for c in reader.connections if c.topic in (CONFIG_TOPIC, FILES_TOPIC)]
        for connection, _, raw in reader.messages(connections=stored) if stored else ():
            msg: Any = reader.deserialize(raw, connection.msgtype)
            if connection.topic == CONFIG_TOPIC:
                config = config if config is not None else msg.data
            else:
                files.setdefault(msg.key, msg.value.encode('utf-8'))
    except Exception as exc:
        raise BagError(f'{path}: corrupt bag: {exc}') from exc
    finally:
        reader.close()
    return Recording(path, 'rosbag2-mcap', config, files)


def frame_connections(connections: list[Connection]) -> list[Connection]:
    return [c for c in connections if c.msgtype == FRAME_TYPE]


def _bag_frames(path: Path) -> Iterator[can.Message]:
    reader = bag_reader(path)
    try:
        count = 0
        try:
            connections = frame_connections(reader.connections)
            for _, _, raw in reader.messages(connections=connections) if connections else ():
                yield decode_frame(raw)
                count += 1
        except (struct.error, IndexError, UnicodeDecodeError) as exc:
            raise BagError(f'{path}: frame {count + 1}: corrupt CanFrame message: {exc}') from exc
        except BagError:
            raise
        except Exception as exc:
            raise BagError(f'{path}: after frame {count}: truncated or corrupt bag: {exc}') from exc
    finally:
        reader.close()


class _Skips(logging.Handler):
    """python-can's text readers log a line they cannot parse and go on: collect those."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def _trace_frames(path: Path, strict: bool, skipped: list[str]) -> Iterator[can.Message]:
    count = 0
    skips = _Skips()
    logger = logging.getLogger('can.io')  # the readers' loggers only, not the rest of python-can
    logger.addHandler(skips)
    reader: Any = None
    try:
        reader = can.LogReader(path)
        size = path.stat().st_size
        if isinstance(reader, can.BLFReader) and reader.file_size > size:
            problem = f'truncated: the BLF header says {reader.file_size} bytes, the file has {size}'
            if strict:
                raise BagError(f'{path}: {problem}')
            skipped.append(problem)
        for msg in reader:
            if skips.messages:
                if strict:
                    raise BagError(f'{path}: after frame {count}: unreadable line (truncated or corrupt?): '
                                   f'{skips.messages[0]}')
                skipped.extend(skips.messages)
                skips.messages.clear()
            yield msg
            count += 1
        if count == 0 and path.stat().st_size > EMPTY_TRACE_BYTES:
            raise BagError(f'{path}: no frame could be read from its {path.stat().st_size} bytes: '
                           f'not a {TRACE_FORMATS.get(path.suffix.lower(), "")} trace, or corrupt')
        if skips.messages:
            if strict:
                raise BagError(f'{path}: after frame {count} (the end): unreadable line (truncated?): '
                               f'{skips.messages[0]}')
            skipped.extend(skips.messages)
    except BagError:
        raise
    except Exception as exc:  # python-can's readers raise ValueError, struct.error, their own...
        raise BagError(f'{path}: after frame {count}: cannot read the trace (truncated or corrupt?): '
                       f'{type(exc).__name__}: {exc}') from exc
    finally:
        logger.removeHandler(skips)
        if reader is not None:
            reader.stop()  # the file closes also when the caller abandons the generator
