"""python-can frames to ``drive_bridge_interfaces/CanFrame`` messages."""
from __future__ import annotations

import can
from builtin_interfaces.msg import Time
from drive_bridge_interfaces.msg import CanFrame


def stamp_from_seconds(seconds: float) -> Time:
    """A ROS time from epoch seconds (python-can timestamps are epoch seconds)."""
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def to_frame_msg(msg: can.Message, channel: str) -> CanFrame:
    """Convert one frame; ``is_rx`` decides the direction."""
    frame = CanFrame()
    frame.header.stamp = stamp_from_seconds(msg.timestamp)
    frame.header.frame_id = channel
    frame.id = msg.arbitration_id
    frame.is_extended = msg.is_extended_id
    frame.is_rtr = msg.is_remote_frame
    frame.is_error = msg.is_error_frame
    frame.dlc = msg.dlc
    frame.data = bytes(msg.data)
    frame.direction = CanFrame.DIRECTION_RX if msg.is_rx else CanFrame.DIRECTION_TX
    return frame
