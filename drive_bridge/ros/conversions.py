"""Core values to ROS messages and back. No CAN frames here: only data the core produced."""
from __future__ import annotations

import math

from builtin_interfaces.msg import Duration, Time
from canopen.objectdictionary import datatypes as dt
from drive_bridge_interfaces.msg import AxisState, Emcy, SdoValue
from trajectory_msgs.msg import JointTrajectory

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.joint import AxisSnapshot
from drive_bridge.master.sdo import SdoPlain
from drive_bridge.ros.frames import stamp_from_seconds
from drive_bridge.streaming.trajectory import Trajectory, TrajectoryPoint

FLOAT_TYPES = {SdoValue.REAL32, SdoValue.REAL64}
STRING_TYPES = {SdoValue.VISIBLE_STRING, SdoValue.UNICODE_STRING}
BYTES_TYPES = {SdoValue.OCTET_STRING, SdoValue.DOMAIN}


def seconds(stamp: Time | Duration) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def sdo_value_to_python(value: SdoValue, data_type: int) -> SdoPlain:
    """The field of ``value`` that ``data_type`` selects (the request's own type, or the
    type from the node's EDS when the request said AUTO)."""
    if data_type == SdoValue.BOOLEAN:
        return bool(value.bool_value)
    if data_type in dt.SIGNED_TYPES:
        return int(value.int_value)
    if data_type in dt.UNSIGNED_TYPES:
        return int(value.uint_value)
    if data_type in FLOAT_TYPES:
        return float(value.float_value)
    if data_type in STRING_TYPES:
        return value.string_value
    if data_type in BYTES_TYPES:
        return bytes(value.bytes_value)
    raise ValueError(f'data_type {data_type} is not a CiA 301 basic type this service supports')


def python_to_sdo_value(data_type: int, plain: SdoPlain, raw: bytes) -> SdoValue:
    """The typed value plus the raw bytes (always filled)."""
    msg = SdoValue(data_type=data_type, bytes_value=bytes(raw))
    if data_type == SdoValue.BOOLEAN:
        msg.bool_value = bool(plain)
    elif data_type in dt.SIGNED_TYPES:
        msg.int_value = int(plain)  # type: ignore[arg-type]
    elif data_type in dt.UNSIGNED_TYPES:
        msg.uint_value = int(plain)  # type: ignore[arg-type]
    elif data_type in FLOAT_TYPES:
        msg.float_value = float(plain)  # type: ignore[arg-type]
    elif data_type in STRING_TYPES:
        msg.string_value = str(plain)
    return msg


def axis_state_msg(snapshot: AxisSnapshot) -> AxisState:
    msg = AxisState()
    msg.header.stamp = stamp_from_seconds(snapshot.stamp) if snapshot.stamp else Time()
    msg.joint_name = snapshot.joint
    msg.node_id = snapshot.node_id
    msg.axis = snapshot.slot
    msg.available = snapshot.available
    msg.nmt_state = str(snapshot.nmt_state)
    msg.state = int(snapshot.state)
    msg.state_name = snapshot.state.label
    msg.drive_state = int(snapshot.drive_state)
    msg.drive_state_name = snapshot.drive_state.label
    msg.mode = max(-128, min(127, snapshot.mode))
    msg.mode_name = snapshot.mode_name
    msg.statusword = snapshot.statusword
    msg.controlword = snapshot.controlword
    msg.fault = snapshot.fault
    msg.warning = snapshot.warning
    msg.target_reached = snapshot.target_reached
    msg.internal_limit_active = snapshot.internal_limit
    msg.following_error = snapshot.following_error
    msg.halted = snapshot.halted
    msg.command_stale = snapshot.command_stale
    msg.message = snapshot.message
    if snapshot.last_emcy is not None:
        msg.last_error_code = snapshot.last_emcy.code
        msg.last_error_text = snapshot.last_emcy.text
    return msg


def emcy_msg(event: EmcyEvent, joint: str) -> Emcy:
    msg = Emcy()
    msg.header.stamp = stamp_from_seconds(event.timestamp)
    msg.node_id = event.node_id
    msg.node_name = event.node_name
    msg.joint_name = joint
    msg.error_code = event.code
    msg.error_register = event.register
    msg.manufacturer_data = list(event.manufacturer)
    msg.text = event.text
    msg.register_text = event.register_text
    msg.severity = event.severity.value
    msg.reset = event.is_reset
    return msg


def trajectory_from_msg(msg: JointTrajectory) -> Trajectory:
    """A core trajectory; header.stamp zero means 'start when received'."""
    start = seconds(msg.header.stamp)
    points = tuple(TrajectoryPoint(seconds(p.time_from_start), tuple(p.positions), tuple(p.velocities),
                                   tuple(p.accelerations)) for p in msg.points)
    return Trajectory(tuple(msg.joint_names), points, start if start > 0 else None)


def finite_or_none(values, index: int) -> float | None:
    """values[index] if present and finite (NaN marks 'not commanded')."""
    if index >= len(values):
        return None
    value = float(values[index])
    return value if math.isfinite(value) else None
