"""``replay --decode``: a recording of raw frames + its bus config -> a bag of decoded topics."""
from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import can

from drive_bridge.bag.decode import OfflineBus
from drive_bridge.bag.decoded_msgs import Topics, to_cdr
from drive_bridge.bag.errors import BagError
from drive_bridge.bag.source import Recording
from drive_bridge.bag.stored import load_stored_config
from drive_bridge.bag.writer import BagWriter
from drive_bridge.config.loader import load_bus_config
from drive_bridge.errors import DriveBridgeError
from drive_bridge.model import BusConfig

DEFAULT_TOPICS = Topics()


def recording_config(recording: Recording, config_path: Path | None) -> BusConfig:
    """The config given on the command line, else the one stored in the bag."""
    if config_path is not None:
        return load_bus_config(config_path)
    if recording.config_yaml is None:
        raise BagError(f'{recording.path}: a {recording.format} recording stores no bus config: '
                       'give one with --config bus.yaml')
    try:
        return load_stored_config(recording.config_yaml, recording.files, f'{recording.path} (stored bus config)')
    except DriveBridgeError as exc:
        raise BagError(f'{recording.path}: the stored bus config does not load: {exc}') from exc


@dataclass
class DecodeStats:
    frames: int = 0
    messages: dict[str, int] = field(default_factory=dict)  # topic -> count
    problems: list[str] = field(default_factory=list)  # where the recording does not fit the config

    def lines(self) -> list[str]:
        return ([f'frames decoded {self.frames}'] + [f'{topic:30s} {count}' for topic, count in
                                                     sorted(self.messages.items())]
                + [f'warning: {problem}' for problem in self.problems])


def decode_into(frames: Iterable[can.Message], config: BusConfig, writer: BagWriter,
                topics: Topics = DEFAULT_TOPICS, on_frame: Callable[[], None] | None = None) -> DecodeStats:
    """Decode frames in order into ``writer`` (the caller closes it); deterministic."""
    bus = OfflineBus(config)
    stats = DecodeStats()
    for msg in frames:
        for sample in bus.feed(msg):
            topic, msgtype, stamp, cdr = to_cdr(sample, topics)
            writer.write(topic, msgtype, stamp, cdr)
            stats.messages[topic] = stats.messages.get(topic, 0) + 1
        stats.frames += 1
        if on_frame is not None:
            on_frame()
    if stats.frames and not bus.node_frames:
        ids = ', '.join(str(n) for n in bus.nodes) or 'none'
        raise BagError(f'none of the {stats.frames} frames is a PDO, EMCY or heartbeat of the configured '
                       f'nodes (ids {ids}): the config does not match the recording')
    stats.problems = bus.problems()
    return stats
