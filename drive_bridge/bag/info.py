"""What a bag or trace holds: topics, types, counts, duration, splits and stored files."""
from __future__ import annotations

from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

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
    start: float  # s since the epoch (or since the trace started)
    duration: float  # s
    topics: tuple[TopicInfo, ...]
    splits: tuple[str, ...] = ()
    files: dict[str, int] = field(default_factory=dict)  # stored file -> bytes
    config: bool = False
    nodes: tuple[int, ...] = ()

    def text(self) -> str:
        start = (datetime.fromtimestamp(self.start, UTC).isoformat(timespec='milliseconds')
                 if self.start > 1e8 else f'{self.start:.3f} s')
        lines = [f'{self.path}', f'  format:   {self.format}', f'  start:    {start}',
                 f'  duration: {self.duration:.3f} s']
        if self.splits:
            lines.append(f'  splits:   {len(self.splits)} ({", ".join(self.splits)})')
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
            start, duration = reader.start_time / 1e9, max(0, reader.end_time - reader.start_time - 1) / 1e9
        finally:
            reader.close()
        splits = tuple(sorted(p.name for p in recording.path.glob('*.mcap'))) if recording.path.is_dir() else ()
        return BagInfo(recording.path, recording.format, start, duration, topics, splits, files,
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
    return BagInfo(recording.path, recording.format, first, last - first, (TopicInfo('(frames)', 'CAN', count),),
                   nodes=tuple(sorted(nodes)))
