"""One way to read every recording: rosbag2 bags of this package, candump logs and pasted
candump screen output, the traces python-can reads, IXXAT MiniMon.

:func:`open_recording` looks at the file's content once (``formats.detect``, or the format the
caller names) and returns a :class:`Recording` whose ``frames()`` iterates the CAN frames in
time order as ``can.Message`` and ``raw_frames()`` as plain tuples (the diagnosis' fast path:
no message objects for candump text), so the tools never care where the frames came from.
rosbags and python-can are imported when a recording needs them, not to read a candump log.
"""
from __future__ import annotations

import struct
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drive_bridge.bag import candump
from drive_bridge.bag.candump import ERR, EXT, FD, RTR, TX, RawFrame
from drive_bridge.bag.errors import BagError
from drive_bridge.bag.formats import FORMATS, check_format, detect

if TYPE_CHECKING:
    import can
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import Connection

EMPTY_TRACE_BYTES = 1024  # a trace this big with no frame is not a trace of that format
_HEAD = struct.Struct('<iII')
_FRAME_HEAD = struct.Struct('<IBBBBI')  # as writer.FRAME_HEAD (not imported: the writer needs python-can)
_READERS = {'trc': 'TRCReader', 'asc': 'ASCReader', 'blf': 'BLFReader', 'csv': 'CSVReader',
            'sqlite': 'SqliteReader', 'mf4': 'MF4Reader'}


def decode_raw(cdr: bytes | memoryview) -> tuple[RawFrame, str, int]:
    """(raw frame, channel, DLC) of a drive_bridge_interfaces/CanFrame in CDR (little-endian), by hand."""
    buf = memoryview(cdr)[4:]
    sec, nsec, length = _HEAD.unpack_from(buf, 0)
    channel = bytes(buf[12:12 + length - 1]).decode('utf-8')
    offset = 12 + length
    offset += -offset % 4
    ident, ext, rtr, err, dlc, size = _FRAME_HEAD.unpack_from(buf, offset)
    offset += _FRAME_HEAD.size
    flags = (EXT if ext else 0) | (RTR if rtr else 0) | (ERR if err else 0) | (TX if buf[offset + size] else 0)
    data = bytes(min(dlc, 8)) if rtr else bytes(buf[offset:offset + size])
    return (sec + nsec * 1e-9, ident, flags, data), channel, dlc


def to_message(frame: RawFrame, channel: str = '', dlc: int | None = None) -> can.Message:
    import can

    t, ident, flags, data = frame
    remote = bool(flags & RTR)
    return can.Message(timestamp=t, arbitration_id=ident, is_extended_id=bool(flags & EXT),
                       is_remote_frame=remote, is_error_frame=bool(flags & ERR), is_fd=bool(flags & FD),
                       dlc=len(data) if dlc is None else dlc, data=b'' if remote else data,
                       is_rx=not flags & TX, channel=channel, check=False)


def raw_of(msg: can.Message) -> RawFrame:
    ident = msg.arbitration_id
    flags = (EXT if msg.is_extended_id else 0) | (RTR if msg.is_remote_frame else 0) | \
        (ERR if msg.is_error_frame or ident > 0x1FFFFFFF else 0) | (0 if msg.is_rx else TX) | (FD if msg.is_fd else 0)
    data = bytes(msg.data)
    if msg.is_remote_frame:
        data = bytes(min(msg.dlc, 8))
    return msg.timestamp, ident & 0x1FFFFFFF, flags, data


@dataclass(frozen=True)
class Recording:
    """What a bag or a trace holds for decoding: its frames and the files stored with it."""

    path: Path
    format: str                  # a name of formats.FORMATS
    config_yaml: str | None      # the bus config stored in the bag (None for vendor traces)
    files: Mapping[str, bytes] = field(default_factory=dict)  # EDS/DCF by the name the config uses
    strict: bool = True          # a line python-can's reader skips is a BagError (else noted in skipped)
    skipped: list[str] = field(default_factory=list)  # lines skipped (strict=False), each with the reason

    def frames(self) -> Iterator[can.Message]:
        """Frames in time order (timestamp in s); BagError naming the frame where the input breaks."""
        if self.format == 'rosbag2-mcap':
            yield from _bag_frames(self.path)
        elif self.format == 'ixxat-minimon':
            from drive_bridge.bag.ixxat import read_minimon
            yield from read_minimon(self.path)
        elif self.format == 'candump':
            count = 0
            for frame, channel in candump.read_log_channels(self.path, self.strict, self.skipped):
                count += 1
                yield to_message(frame, channel)
            self._check_empty(count)
        elif self.format == 'candump-screen':
            for frame in self._text_frames():
                yield to_message(frame, 'can0')  # a paste: its interface column is not kept
        else:
            yield from _trace_frames(self.path, self.format, self.strict, self.skipped)

    def raw_frames(self) -> Iterator[RawFrame]:
        """The same frames as plain tuples (time, identifier, flags, data): no message objects."""
        if self.format in ('candump', 'candump-screen'):
            yield from self._text_frames()
        elif self.format == 'rosbag2-mcap':
            for frame, _channel, _dlc in _bag_raw(self.path):
                yield frame
        else:
            for msg in self.frames():
                yield raw_of(msg)

    def frames_for_bag(self) -> Iterator[tuple[RawFrame, str, int]]:
        """(frame, channel, DLC) as a bag stores them (a remote frame's data empty), no message
        objects for candump text and bags: the importer's fast path; the same fields as ``frames()``."""
        if self.format == 'candump':
            count = 0
            for (t, ident, flags, data), channel in candump.read_log_channels(self.path, self.strict, self.skipped):
                count += 1
                yield ((t, ident, flags, b''), channel, len(data)) if flags & RTR else ((t, ident, flags, data),
                                                                                        channel, len(data))
            self._check_empty(count)
        elif self.format == 'candump-screen':
            for t, ident, flags, data in self._text_frames():
                yield ((t, ident, flags, b'') if flags & RTR else (t, ident, flags, data)), 'can0', len(data)
        elif self.format == 'rosbag2-mcap':
            for (t, ident, flags, data), channel, dlc in _bag_raw(self.path):
                yield ((t, ident, flags, b'') if flags & RTR else (t, ident, flags, data)), channel, dlc
        else:
            for msg in self.frames():
                flags = (EXT if msg.is_extended_id else 0) | (RTR if msg.is_remote_frame else 0) | \
                    (ERR if msg.is_error_frame else 0) | (0 if msg.is_rx else TX) | (FD if msg.is_fd else 0)
                yield ((msg.timestamp, msg.arbitration_id, flags, bytes(msg.data)),
                       str(msg.channel if msg.channel is not None else ''), msg.dlc)

    def _text_frames(self) -> Iterator[RawFrame]:
        read = candump.read_log if self.format == 'candump' else candump.read_screen
        count = 0
        for frame in read(self.path, self.strict, self.skipped):
            count += 1
            yield frame
        self._check_empty(count)

    def _check_empty(self, count: int) -> None:
        if count == 0 and self.path.stat().st_size > EMPTY_TRACE_BYTES:
            raise BagError(f'{self.path}: no frame could be read from its {self.path.stat().st_size} bytes: '
                           f'not a {self.format} log, or corrupt')


def open_recording(path: Path, strict: bool = True, fmt: str | None = None) -> Recording:
    """A rosbag2 directory or .mcap file, a candump log or pasted screen output, any trace
    python-can reads, an IXXAT MiniMon trace: by content unless ``fmt`` names the format;
    BagError naming the file and what is wrong (missing, unknown format, truncated...)."""
    path = Path(path)
    if not path.exists():
        raise BagError(f'{path}: no such file or directory')
    name = check_format(fmt) if fmt else detect(path)
    if name == 'rosbag2-mcap':
        return _open_bag(path)
    if path.is_dir():
        raise BagError(f'{path}: a directory is a rosbag2 bag, not a {FORMATS[name]}')
    return Recording(path, name, None, {}, strict)


def bag_reader(path: Path) -> AnyReader:
    from rosbags.highlevel import AnyReader

    from drive_bridge.bag.typestore import typestore
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
    from drive_bridge.bag.writer import CONFIG_TOPIC, FILES_TOPIC
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
    from drive_bridge.bag.writer import FRAME_TYPE
    return [c for c in connections if c.msgtype == FRAME_TYPE]


def _bag_frames(path: Path) -> Iterator[can.Message]:
    for frame, channel, dlc in _bag_raw(path):
        yield to_message(frame, channel, dlc)


def _bag_raw(path: Path) -> Iterator[tuple[RawFrame, str, int]]:
    reader = bag_reader(path)
    try:
        count = 0
        try:
            connections = frame_connections(reader.connections)
            for _, _, raw in reader.messages(connections=connections) if connections else ():
                yield decode_raw(raw)
                count += 1
        except (struct.error, IndexError, UnicodeDecodeError) as exc:
            raise BagError(f'{path}: frame {count + 1}: corrupt CanFrame message: {exc}') from exc
        except BagError:
            raise
        except Exception as exc:
            raise BagError(f'{path}: after frame {count}: truncated or corrupt bag: {exc}') from exc
    finally:
        reader.close()


def _skips() -> Any:
    """A logging handler that collects what python-can's text readers log of a line they cannot
    parse (and go on): logging is imported with python-can, not to read candump text."""
    import logging

    class Skips(logging.Handler):
        def __init__(self) -> None:
            super().__init__(logging.WARNING)
            self.messages: list[str] = []

        def emit(self, record: logging.LogRecord) -> None:
            self.messages.append(record.getMessage())

    return Skips()


def _trace_frames(path: Path, fmt: str, strict: bool, skipped: list[str]) -> Iterator[can.Message]:
    import logging

    import can

    count = 0
    skips = _skips()
    logger = logging.getLogger('can.io')  # the readers' loggers only, not the rest of python-can
    logger.addHandler(skips)
    reader: Any = None
    try:
        reader = getattr(can, _READERS[fmt])(path)
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
                           f'not a {fmt} trace, or corrupt')
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
