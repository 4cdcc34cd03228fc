"""What a bag or trace holds: topics, types, counts, duration, splits and stored files."""
from __future__ import annotations

from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import yaml

from drive_bridge.bag.importer import node_of
from drive_bridge.bag.source import bag_reader, open_recording


@dataclass(frozen=True)
class TopicInfo:
    topic: str
    msgtype: str
    count: int


@dataclass(frozen=True)
class BagInfo:
    path: Path
    format: str
    start: float | None  # s since the epoch (or since the trace started); None: no messages
    duration: float | None  # s; None: no messages
    topics: tuple[TopicInfo, ...]
    splits: tuple[str, ...] = ()  # as metadata.yaml lists them
    unlisted: tuple[str, ...] = ()  # .mcap files metadata.yaml does not list (a killed recorder's)
    files: dict[str, int] = field(default_factory=dict)  # stored file -> bytes
    config: bool = False
    nodes: tuple[int, ...] = ()

    def text(self) -> str:
        if self.start is None:
            start = '(no messages)'
        else:
            start = (datetime.fromtimestamp(self.start, UTC).isoformat(timespec='milliseconds')
                     if self.start > 1e8 else f'{self.start:.3f} s')
        duration = f'{self.duration:.3f} s' if self.duration is not None else '(no messages)'
        lines = [f'{self.path}', f'  format:   {self.format}', f'  start:    {start}', f'  duration: {duration}']
        if self.splits:
            lines.append(f'  splits:   {len(self.splits)} ({", ".join(self.splits)})')
        if self.unlisted:
            lines.append(f'  warning:  {len(self.unlisted)} split(s) not in metadata.yaml: run drive-bridge recover '
                         f'({", ".join(self.unlisted)})')
        if self.nodes:
            lines.append(f'  node ids: {", ".join(map(str, self.nodes))}')
        lines.append(f'  messages: {sum(t.count for t in self.topics)}')
        width = max((len(t.topic) for t in self.topics), default=0)
        lines += [f'    {t.topic:<{width}}  {t.count:>9}  {t.msgtype}' for t in self.topics]
        lines.append(f'  bus config stored: {"yes" if self.config else "no"}')
        lines += [f'  file: {name} ({size} bytes)' for name, size in sorted(self.files.items())]
        return '\n'.join(lines)


def info(path: Path) -> BagInfo:
    """Read the summary of a bag (its metadata) or scan a trace once."""
    recording = open_recording(Path(path))
    files = {name: len(data) for name, data in recording.files.items()}
    if recording.format == 'rosbag2-mcap':
        reader = bag_reader(recording.path)
        try:
            counts: dict[tuple[str, str], int] = {}
            for c in reader.connections:
                counts[(c.topic, c.msgtype)] = counts.get((c.topic, c.msgtype), 0) + c.msgcount
            topics = tuple(TopicInfo(t, m, n) for (t, m), n in sorted(counts.items()))
            start: float | None = None
            duration: float | None = None
            if reader.message_count:  # else rosbags' start is its sentinel (2262-04-11)
                start, duration = reader.start_time / 1e9, max(0, reader.end_time - reader.start_time - 1) / 1e9
        finally:
            reader.close()
        splits, unlisted = _splits(recording.path) if recording.path.is_dir() else ((), ())
        return BagInfo(recording.path, recording.format, start, duration, topics, splits, unlisted, files,
                       recording.config_yaml is not None)
    count = 0
    first = last = 0.0
    nodes: set[int] = set()
    for msg in recording.frames():
        if count == 0:
            first = msg.timestamp
        last = msg.timestamp
        count += 1
        if not msg.is_extended_id and (node := node_of(msg.arbitration_id)) is not None:
            nodes.add(node)
    return BagInfo(recording.path, recording.format, first if count else None, last - first if count else None,
                   (TopicInfo('(frames)', 'CAN', count),), nodes=tuple(sorted(nodes)))


def _splits(bag: Path) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(the splits metadata.yaml lists, the .mcap files beside them it does not)."""
    try:
        meta = yaml.safe_load((bag / 'metadata.yaml').read_text(encoding='utf-8'))
        listed = tuple(str(p) for p in meta['rosbag2_bagfile_information']['relative_file_paths'])
    except (OSError, yaml.YAMLError, KeyError, TypeError):
        listed = ()
    unlisted = tuple(sorted(p.name for p in bag.glob('*.mcap') if p.name not in listed))
    return listed, unlisted
