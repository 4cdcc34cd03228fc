"""Size limits on what a client may send, checked before a message is turned into objects.

rclpy turns a received message into Python objects before any callback sees it, and that
work grows with the message: one 200,000-point JointTrajectory took seconds and starved
the SYNC cycle and the supervision of every node. So the trajectory topic is subscribed
raw (serialized CDR bytes) and :func:`trajectory_counts` reads the joint and point
counts from the first bytes; only a message within the limits is deserialized.
"""
from __future__ import annotations

import struct

from drive_bridge.ros.errors import MalformedMessage, MessageTooLarge
from drive_bridge.streaming.trajectory import MAX_TRAJECTORY_POINTS

MAX_JOINT_NAMES = 64  # far more than one bus has; a longer list is an error, not a command
ENCAPSULATION = 4  # CDR header (representation id and options); alignment counts from its end
_LITTLE = {b'\x00\x01', b'\x00\x07'}  # CDR_LE, CDR2_LE (XCDR2: a final type, plain members)
_BIG = {b'\x00\x00', b'\x00\x06'}  # CDR_BE, CDR2_BE
_PARAMETER_LIST = {b'\x00\x02', b'\x00\x03'}  # PL_CDR: members as parameters, another layout
POINT_FIXED = 16  # per point: time_from_start (8) and alignment
SEQUENCE_FIXED = 8  # per float64[] of a point: its length (4) and alignment to 8


class _Reader:
    def __init__(self, raw: bytes) -> None:
        kind = bytes(raw[:2])
        if kind in _PARAMETER_LIST:
            raise MalformedMessage(f'CDR encapsulation 0x{kind.hex()} (parameter list, PL_CDR) is not supported; '
                                   'send plain CDR or XCDR2')
        if kind not in _LITTLE | _BIG:
            raise MalformedMessage(f'unknown CDR encapsulation 0x{kind.hex()}')
        self.raw = raw
        self.pos = ENCAPSULATION
        self.uint = struct.Struct('<I' if kind in _LITTLE else '>I')

    def u32(self) -> int:
        self.pos += -(self.pos - ENCAPSULATION) % 4
        if self.pos + 4 > len(self.raw):
            raise MalformedMessage(f'message ends at byte {len(self.raw)}, inside its header')
        value = int(self.uint.unpack_from(self.raw, self.pos)[0])
        self.pos += 4
        return value

    def skip_string(self) -> None:
        length = self.u32()  # counts the terminating NUL
        self.pos += length


def trajectory_counts(raw: bytes) -> tuple[int, int]:
    """(joint names, points) of a serialized trajectory_msgs/JointTrajectory."""
    joints, points, _ = _trajectory_header(raw)
    return joints, points


def check_trajectory_bytes(raw: bytes) -> None:
    """MessageTooLarge for a trajectory bigger than its joint and point counts allow: the
    counts alone do not bound a message whose points carry long per-point arrays."""
    joints, points, header = _trajectory_header(raw)
    check_trajectory_size(joints, points)
    limit = header + points * (POINT_FIXED + 4 * (SEQUENCE_FIXED + 8 * joints)) + ENCAPSULATION
    if len(raw) > limit:
        raise MessageTooLarge(f'{len(raw)} bytes, more than the {limit} bytes {joints} joint name(s) and '
                              f'{points} point(s) can take (each point at most 4 arrays of one float64 per joint)')


def _trajectory_header(raw: bytes) -> tuple[int, int, int]:
    """(joint names, points, bytes up to the points)."""
    reader = _Reader(raw)
    reader.u32()  # header.stamp.sec
    reader.u32()  # header.stamp.nanosec
    reader.skip_string()  # header.frame_id
    joints = reader.u32()
    if joints > MAX_JOINT_NAMES:
        return joints, 0, reader.pos
    for _ in range(joints):
        reader.skip_string()
    points = reader.u32()
    return joints, points, reader.pos


def check_trajectory_size(joints: int, points: int) -> None:
    """MessageTooLarge naming the count and its limit."""
    if joints > MAX_JOINT_NAMES:
        raise MessageTooLarge(f'{joints} joint names, more than the limit of {MAX_JOINT_NAMES}')
    if points > MAX_TRAJECTORY_POINTS:
        raise MessageTooLarge(f'{points} points, more than the limit of {MAX_TRAJECTORY_POINTS}; '
                              'send it in shorter pieces (each new trajectory splices onto the running one)')
