"""Making a bag readable after its recorder was killed.

A killed recorder leaves its open split without the MCAP summary (and possibly with a torn
last record), and ``metadata.yaml`` listing only the closed splits. :func:`recover` rewrites
each such split from the records it still holds (read sequentially up to the first broken
one; the original is kept as ``<split>.unrecovered``) and writes ``metadata.yaml`` for every
split, so rosbags, ``ros2 bag`` and the mcap tools read the whole bag.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.writer import CHUNK_BYTES, SplitInfo, write_metadata

MAGIC = b'\x89MCAP0\r\n'


@dataclass
class RecoveredSplit:
    path: Path
    messages: int
    rewritten: bool  # False: the split was complete already
    problem: str = ''  # why it had to be rewritten


@dataclass
class RecoverReport:
    path: Path
    splits: list[RecoveredSplit] = field(default_factory=list)

    def summary(self) -> str:
        fixed = [s for s in self.splits if s.rewritten]
        lines = [f'{self.path}: {len(self.splits)} split(s), {len(fixed)} recovered, '
                 f'{sum(s.messages for s in self.splits)} messages']
        lines += [f'  {s.path.name}: {s.messages} messages recovered ({s.problem})' for s in fixed]
        return '\n'.join(lines)


def _split_index(path: Path) -> int:
    tail = path.stem.rsplit('_', 1)[-1]
    return int(tail) if tail.isdigit() else -1


def summary_problem(path: Path) -> str:
    """'' when the split's summary reads, else what is wrong."""
    try:
        with path.open('rb') as stream:
            stream.seek(max(0, path.stat().st_size - len(MAGIC)))
            if stream.read() != MAGIC:
                return 'not closed: no MCAP footer (recorder killed?)'
    except OSError as exc:
        return f'unreadable: {exc.strerror}'
    try:
        with path.open('rb') as stream:
            summary = make_reader(stream).get_summary()
    except (McapError, OSError, ValueError, EOFError) as exc:
        return f'{type(exc).__name__}: {exc}' if str(exc) else type(exc).__name__
    return '' if summary is not None and summary.statistics is not None else 'no summary'


def rewrite_split(path: Path) -> int:
    """Rewrite ``path`` from its readable records; returns the number of messages kept."""
    with path.open('rb') as stream:
        if stream.read(len(MAGIC)) != MAGIC:
            raise BagError(f'{path}: not an MCAP file (no MCAP magic at the start), nothing to recover')
    tmp = path.with_suffix('.mcap.tmp')
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    count = 0
    with path.open('rb') as source, tmp.open('wb') as target:
        writer = Writer(target, chunk_size=CHUNK_BYTES, compression=CompressionType.LZ4)
        writer.start(profile='ros2', library='drive_bridge recover')
        try:
            for record in StreamReader(source, validate_crcs=True).records:
                if isinstance(record, Schema) and record.id not in schemas:
                    schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
                elif isinstance(record, Channel) and record.id not in channels:
                    channels[record.id] = writer.register_channel(
                        record.topic, record.message_encoding, schemas.get(record.schema_id, 0), record.metadata)
                elif isinstance(record, Message) and record.channel_id in channels:
                    writer.add_message(channels[record.channel_id], record.log_time, record.data,
                                       record.publish_time, record.sequence)
                    count += 1
                elif isinstance(record, Attachment):
                    writer.add_attachment(record.create_time, record.log_time, record.name, record.media_type,
                                          record.data)
        except Exception:  # noqa: S110  the torn tail of a killed recording: keep what came before
            pass
        writer.finish()
    path.replace(path.with_suffix('.mcap.unrecovered'))
    tmp.replace(path)
    return count


def split_info(path: Path) -> tuple[SplitInfo, dict[str, str]]:
    """A complete split's entry for metadata.yaml, and its topics' types."""
    with path.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    if summary is None or summary.statistics is None:
        raise BagError(f'{path}: no summary after recovery')
    stats = summary.statistics
    topics: dict[str, int] = {}
    types: dict[str, str] = {}
    for cid, channel in summary.channels.items():
        topics[channel.topic] = topics.get(channel.topic, 0) + stats.channel_message_counts.get(cid, 0)
        schema = summary.schemas.get(channel.schema_id)
        types[channel.topic] = schema.name if schema is not None else ''
    return SplitInfo(path.name, stats.message_start_time, stats.message_end_time, stats.message_count, topics), types


def recover(path: Path) -> RecoverReport:
    """Recover the bag directory (or one .mcap split) at ``path``; BagError if it is none."""
    path = Path(path)
    if not path.exists():
        raise BagError(f'{path}: no such file or directory')
    if path.is_file() and path.suffix != '.mcap':
        raise BagError(f'{path}: not a rosbag2 MCAP bag (a directory or a .mcap file)')
    splits = [path] if path.is_file() else sorted(path.glob('*.mcap'), key=lambda p: (_split_index(p), p.name))
    if not splits:
        raise BagError(f'{path}: no .mcap split in the directory')
    report = RecoverReport(path)
    infos: list[SplitInfo] = []
    types: dict[str, str] = {}
    for split in splits:
        size = split.stat().st_size
        if path.is_dir() and size < len(MAGIC):  # killed before its header reached the disk
            split.replace(split.with_suffix('.mcap.empty'))
            report.splits.append(RecoveredSplit(split, 0, True, f'{size} bytes, no MCAP header: '
                                                'moved aside as .mcap.empty'))
            continue
        problem = summary_problem(split)
        if problem:
            messages = rewrite_split(split)
            report.splits.append(RecoveredSplit(split, messages, True, problem))
        info, split_types = split_info(split)
        if not problem:
            report.splits.append(RecoveredSplit(split, info.count, False))
        infos.append(info)
        types.update(split_types)
    if path.is_dir():
        write_metadata(path, infos, types)
    return report
