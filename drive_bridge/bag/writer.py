"""Writing rosbag2 MCAP bags with splits, from raw CDR and from CAN frames.

Layout as ``ros2 bag record`` makes it: a directory ``NAME/`` with ``NAME_0.mcap``,
``NAME_1.mcap``... and ``metadata.yaml``. Each split is a complete MCAP file (schemas with
the message definitions, chunk indexes, summary) written with the ``mcap`` library, and
``metadata.yaml`` is rewritten each time a split closes, so a recorder killed mid-split
leaves a readable bag of its closed splits (``drive-bridge recover`` adds the last one).
Every split starts with the bus config (``/bag/config``, std_msgs/String) and the EDS/DCF
files (``/bag/files``, diagnostic_msgs/KeyValue, key = the name the config uses), also as
MCAP attachments, so each split can be decoded on its own.

Not thread-safe: one thread (the recorder's writer thread) owns a writer.
"""
from __future__ import annotations

import struct
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, TYPE_CHECKING

import yaml
from mcap.writer import CompressionType, Writer

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.typestore import typestore

if TYPE_CHECKING:  # frames arrive as can.Message from the recorder; the importer needs no python-can
    import can

FRAMES_TOPIC = '/can/frames'
FRAME_TYPE = 'drive_bridge_interfaces/msg/CanFrame'
CONFIG_TOPIC = '/bag/config'
CONFIG_TYPE = 'std_msgs/msg/String'
FILES_TOPIC = '/bag/files'
FILES_TYPE = 'diagnostic_msgs/msg/KeyValue'
CHUNK_BYTES = 256 * 1024  # what a killed recorder loses of a split at most, besides the summary
RECORD_OVERHEAD = 31      # bytes an MCAP message record adds to its payload
ROSBAG2_VERSION = 9

FRAME_HEAD = struct.Struct('<IBBBBI')  # CanFrame: id, ext, rtr, err, dlc, data length (writer and reader)
_CDR_LE = b'\x00\x01\x00\x00'


def cdr_string(text: str) -> bytes:
    """A CDR string at a 4-aligned offset: length (with NUL), bytes, NUL, padding to 4."""
    raw = text.encode('utf-8') + b'\x00'
    return struct.pack('<I', len(raw)) + raw + b'\x00' * (-len(raw) % 4)


def string_cdr(text: str) -> bytes:
    """std_msgs/String."""
    return bytes(typestore().serialize_cdr(typestore().types[CONFIG_TYPE](data=text), CONFIG_TYPE))


def key_value_cdr(key: str, value: str) -> bytes:
    """diagnostic_msgs/KeyValue."""
    return bytes(typestore().serialize_cdr(typestore().types[FILES_TYPE](key=key, value=value), FILES_TYPE))


def file_text(data: bytes) -> str:
    """A stored file as text (CDR strings are UTF-8): EDS files in latin-1 keep their characters."""
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError:
        return data.decode('latin-1')


class FrameEncoder:
    """CanFrame CDR by hand (struct, no message objects): the recorder's and the importer's hot
    path. Per channel one struct packs the CDR header, the stamp, the frame id and the frame's
    fixed fields; the data bytes and the direction byte follow."""

    def __init__(self) -> None:
        self._heads: dict[str, struct.Struct] = {}
        self._frame_ids: dict[str, bytes] = {}

    def encode(self, msg: can.Message, channel: str) -> tuple[int, bytes]:
        """(timestamp ns, CDR) of a frame; direction TX for frames the master sent."""
        return self.pack(msg.timestamp, msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame,
                         msg.is_error_frame, not msg.is_rx, msg.dlc, bytes(msg.data), channel)

    def pack(self, timestamp: float, ident: int, ext: bool, rtr: bool, err: bool, tx: bool, dlc: int,
             data: bytes, channel: str) -> tuple[int, bytes]:
        """(timestamp ns, CDR) of a frame given by its fields (``data``: the data field as stored)."""
        stamp = round(timestamp * 1e9)
        head = self._heads.get(channel)
        if head is None:
            head = self._head(channel)
        sec, nsec = divmod(stamp, 1_000_000_000)
        return stamp, head.pack(_CDR_LE, sec, nsec, self._frame_ids[channel], ident, ext, rtr, err, dlc,
                                len(data)) + data + (b'\x01' if tx else b'\x00')

    def _head(self, channel: str) -> struct.Struct:
        frame_id = self._frame_ids[channel] = cdr_string(channel)
        head = self._heads[channel] = struct.Struct(f'<4siI{len(frame_id)}s{FRAME_HEAD.format[1:]}')
        return head


@dataclass
class TopicStats:
    msgtype: str
    count: int = 0


@dataclass
class SplitInfo:
    """What metadata.yaml says of one closed split."""
    path: str
    start_ns: int
    end_ns: int
    count: int
    topics: dict[str, int] = field(default_factory=dict)


class BagWriter:
    """A rosbag2 MCAP bag written from raw CDR, rotated by size and/or time."""

    def __init__(self, path: Path, *, split_bytes: int | None = None, split_seconds: float | None = None,
                 config_yaml: str | None = None, files: Mapping[str, bytes] = {},
                 compression: CompressionType = CompressionType.LZ4) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f'{self.path}: exists already; a bag is never overwritten')
        try:
            self.path.mkdir(parents=True)
        except OSError as exc:
            raise BagError(f'{self.path}: cannot create the bag directory: {exc.strerror}') from exc
        self.split_bytes = split_bytes if split_bytes and split_bytes > 0 else None
        self.split_ns = round(split_seconds * 1e9) if split_seconds and split_seconds > 0 else None
        self.config_yaml = config_yaml
        self.custom: dict[str, str] = {}  # more of metadata.yaml's custom_data (e.g. frames lost before the bag)
        self.files = dict(files)
        self._compression = compression
        self._encoder = FrameEncoder()
        self.topics: dict[str, TopicStats] = {}       # over the whole bag
        self.splits: list[SplitInfo] = []              # closed splits
        self.bytes_written = 0                         # payload + record overhead, whole bag
        self.frames = 0
        self.messages = 0  # all topics' messages: read from other threads (``topics`` changes under them)
        self._stream: IO[bytes] | None = None
        self._mcap: Writer | None = None
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._split: SplitInfo | None = None
        self._split_bytes = 0
        self.closed = False

    # -- public --------------------------------------------------------------------------------
    @property
    def current_split(self) -> Path | None:
        return self.path / self._split.path if self._split else None

    def write(self, topic: str, msgtype: str, timestamp_ns: int, cdr: bytes) -> None:
        """One message of raw CDR (``rclpy.serialization.serialize_message`` or the typestore's)."""
        if self.closed:
            raise BagError(f'{self.path}: bag is closed')
        split = self._split
        if split is None or self._must_rotate(split, timestamp_ns):
            if split is not None:
                self._close_split()
            split = self._open_split(timestamp_ns)
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._add_channel(topic, msgtype)
        assert self._mcap is not None
        self._mcap.add_message(channel, timestamp_ns, cdr, timestamp_ns)
        split.count += 1
        self.messages += 1
        split.topics[topic] = split.topics.get(topic, 0) + 1
        split.start_ns = min(split.start_ns, timestamp_ns)
        split.end_ns = max(split.end_ns, timestamp_ns)
        stats = self.topics.get(topic)
        if stats is None:
            stats = self.topics[topic] = TopicStats(msgtype)
        stats.count += 1
        size = len(cdr) + RECORD_OVERHEAD
        self._split_bytes += size
        self.bytes_written += size

    def write_frame(self, msg: can.Message, channel: str = '') -> None:
        """One CAN frame on ``/can/frames``; header.stamp = log time = the bus timestamp."""
        stamp, cdr = self._encoder.encode(msg, channel or str(msg.channel or ''))
        self.write(FRAMES_TOPIC, FRAME_TYPE, stamp, cdr)
        self.frames += 1

    def write_frames(self, frames: Iterable[tuple[int, bytes]]) -> None:
        """Many CAN frames, (timestamp ns, CDR) as ``FrameEncoder`` makes them, on ``/can/frames``:
        an importer's loop. A bag that does not split takes them in one tight loop (the counts and
        times updated once); one that splits, frame by frame as ``write_frame``."""
        frames = iter(frames)
        if self.split_bytes is not None or self.split_ns is not None or self.closed:
            for stamp, cdr in frames:
                self.write(FRAMES_TOPIC, FRAME_TYPE, stamp, cdr)
                self.frames += 1
            return
        for stamp, cdr in frames:  # the first: opens the split and the channel
            self.write(FRAMES_TOPIC, FRAME_TYPE, stamp, cdr)
            self.frames += 1
            break
        split = self._split
        if split is None:
            return
        assert self._mcap is not None
        add = self._mcap.add_message
        channel = self._channels[FRAMES_TOPIC]
        count = size = 0
        low, high = split.start_ns, split.end_ns
        try:
            for stamp, cdr in frames:
                add(channel, stamp, cdr, stamp)
                count += 1
                size += len(cdr)
                if stamp < low:
                    low = stamp
                elif stamp > high:
                    high = stamp
        finally:
            split.count += count
            split.topics[FRAMES_TOPIC] += count
            split.start_ns, split.end_ns = low, high
            self.topics[FRAMES_TOPIC].count += count
            self.messages += count
            self.frames += count
            self._split_bytes += size + count * RECORD_OVERHEAD
            self.bytes_written += size + count * RECORD_OVERHEAD

    def flush(self) -> None:
        """Write the pending chunk to disk: a killed recorder loses only what came after."""
        if self._mcap is not None:
            self._mcap.flush()

    def close(self) -> None:
        """Close the current split and write the final metadata.yaml (idempotent)."""
        if self.closed:
            return
        if self._split is not None:
            self._close_split()
        else:
            self._write_metadata()
        self.closed = True

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- splits --------------------------------------------------------------------------------
    def _must_rotate(self, split: SplitInfo, timestamp_ns: int) -> bool:
        if self.split_bytes is not None and split.count % 64 == 0 and self._file_bytes() >= self.split_bytes:
            return True
        return self.split_ns is not None and timestamp_ns - split.start_ns >= self.split_ns

    def _file_bytes(self) -> int:
        """Bytes of the split on disk (closed chunks) plus the pending chunk, uncompressed."""
        assert self._stream is not None
        return self._stream.tell() + min(self._split_bytes, CHUNK_BYTES)

    def _open_split(self, timestamp_ns: int) -> SplitInfo:
        name = f'{self.path.name}_{len(self.splits)}.mcap'
        try:
            self._stream = open(self.path / name, 'xb')  # noqa: SIM115  closed in _close_split
        except OSError as exc:
            raise BagError(f'{self.path / name}: cannot create split: {exc.strerror}') from exc
        self._mcap = Writer(self._stream, chunk_size=CHUNK_BYTES, compression=self._compression)
        self._mcap.start(profile='ros2', library='drive_bridge')
        self._stream.flush()  # the magic and header on disk now: a recorder killed at once leaves an MCAP file
        self._channels = {}
        self._schemas = {}
        self._split_bytes = 0
        self._split = SplitInfo(name, timestamp_ns, timestamp_ns, 0)
        self._store_files(timestamp_ns)
        return self._split

    def _store_files(self, timestamp_ns: int) -> None:
        assert self._mcap is not None
        now = time.time_ns()
        if self.config_yaml is not None:
            self._mcap.add_attachment(now, timestamp_ns, 'bus.yaml', 'application/yaml',
                                      self.config_yaml.encode('utf-8'))
            self.write(CONFIG_TOPIC, CONFIG_TYPE, timestamp_ns, string_cdr(self.config_yaml))
        for name, data in self.files.items():
            self._mcap.add_attachment(now, timestamp_ns, name, 'text/plain', data)
            self.write(FILES_TOPIC, FILES_TYPE, timestamp_ns, key_value_cdr(name, file_text(data)))

    def _add_channel(self, topic: str, msgtype: str) -> int:
        assert self._mcap is not None
        schema = self._schemas.get(msgtype)
        if schema is None:
            try:
                msgdef, _ = typestore().generate_msgdef(msgtype, ros_version=2)
            except Exception as exc:
                raise BagError(f'{self.path}: topic {topic}: unknown message type {msgtype!r}') from exc
            schema = self._schemas[msgtype] = self._mcap.register_schema(msgtype, 'ros2msg', msgdef.encode())
        channel = self._mcap.register_channel(topic, 'cdr', schema, {'offered_qos_profiles': ''})
        self._channels[topic] = channel
        return channel

    def _close_split(self) -> None:
        assert self._mcap is not None and self._stream is not None and self._split is not None
        self._mcap.finish()
        self._stream.close()
        self.splits.append(self._split)
        self._split = None
        self._mcap = None
        self._stream = None
        self._write_metadata()

    def _write_metadata(self) -> None:
        write_metadata(self.path, self.splits, {t: s.msgtype for t, s in self.topics.items()}, self.custom)


def write_metadata(path: Path, splits: list[SplitInfo], types: Mapping[str, str],
                   custom: Mapping[str, str] = {}) -> None:
    """``metadata.yaml`` (rosbag2 version 9) for the given splits, replaced atomically."""
    store = typestore()
    counts: dict[str, int] = {}
    for split in splits:
        for topic, count in split.topics.items():
            counts[topic] = counts.get(topic, 0) + count
    start = min((s.start_ns for s in splits if s.count), default=0)
    end = max((s.end_ns for s in splits if s.count), default=0)
    info = {
        'version': ROSBAG2_VERSION,
        'storage_identifier': 'mcap',
        'relative_file_paths': [s.path for s in splits],
        'duration': {'nanoseconds': end - start},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': sum(s.count for s in splits),
        'topics_with_message_count': [
            {'topic_metadata': {'name': topic, 'type': types[topic], 'serialization_format': 'cdr',
                                'offered_qos_profiles': [],
                                'type_description_hash': store.hash_rihs01(types[topic])},
             'message_count': count}
            for topic, count in counts.items()],
        'compression_format': '',
        'compression_mode': '',
        'files': [{'path': s.path, 'starting_time': {'nanoseconds_since_epoch': s.start_ns},
                   'duration': {'nanoseconds': s.end_ns - s.start_ns}, 'message_count': s.count}
                  for s in splits],
        'custom_data': {'writer': 'drive_bridge', **custom},
        'ros_distro': 'jazzy',
    }
    tmp = path / 'metadata.yaml.tmp'
    tmp.write_text(yaml.safe_dump({'rosbag2_bagfile_information': info}, sort_keys=False), 'utf-8')
    tmp.replace(path / 'metadata.yaml')
