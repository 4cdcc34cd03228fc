"""The ``record`` section (where and how the bridge records the bus, rosbag2 MCAP) and the
``trajectory`` section (trajectories beyond the limits)."""
from __future__ import annotations

from drive_bridge.config import keys
from drive_bridge.config.reader import Section
from drive_bridge.model import RecordConfig, TrajectoryConfig


def parse_record(sec: Section | None) -> RecordConfig:
    base = RecordConfig()
    if sec is None:
        return base
    sec.check_keys(keys.RECORD)
    path = sec.get_str('path', base.path)
    if not path:
        sec.issues.error(sec.loc('path'), 'expected a directory for the bags, got an empty string')
    return RecordConfig(
        path=path or base.path,
        split_size_mb=sec.get_number('split_size_mb', base.split_size_mb, ge=0) or 0.0,
        split_seconds=sec.get_number('split_seconds', base.split_seconds, ge=0) or 0.0,
        start=sec.get_bool('start', base.start))


def parse_trajectory(sec: Section | None) -> TrajectoryConfig:
    if sec is None:
        return TrajectoryConfig()
    sec.check_keys(keys.TRAJECTORY)
    return TrajectoryConfig(scale_to_limits=sec.get_bool('scale_to_limits', False))
