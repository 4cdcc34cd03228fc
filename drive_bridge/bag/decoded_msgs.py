"""Decoded samples to the bridge's ROS messages as CDR, with the rosbags typestore (no rclpy).

Field by field what ``drive_bridge.ros.conversions`` and ``ros.state_topics`` publish live,
so a decoded bag and a live recording read the same in Foxglove or PlotJuggler.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from drive_bridge.bag.decode import AxisStatesSample, BusNotice, Decoded, EmcySample, JointSample
from drive_bridge.bag.typestore import typestore
from drive_bridge.joint import AxisSnapshot
from drive_bridge.master.events import Level

JOINT_STATE = 'sensor_msgs/msg/JointState'
AXIS_STATES = 'drive_bridge_interfaces/msg/AxisStates'
AXIS_STATE = 'drive_bridge_interfaces/msg/AxisState'
EMCY = 'drive_bridge_interfaces/msg/Emcy'
LOG = 'rcl_interfaces/msg/Log'
LOG_LEVEL = {Level.INFO: 20, Level.WARN: 30, Level.ERROR: 40}


@dataclass(frozen=True)
class Topics:
    """Where the decoded samples go: the bridge's own names for a node named ``namespace``."""

    namespace: str = '/drive_bridge'
    joint_states: str = '/joint_states'

    @property
    def axis_states(self) -> str:
        return f'{self.namespace}/axis_states'

    @property
    def emcy(self) -> str:
        return f'{self.namespace}/emcy'

    @property
    def bus_events(self) -> str:
        return f'{self.namespace}/events'  # as the bridge's recorder writes its bus events


def ns(seconds: float) -> int:
    return round(seconds * 1e9)


def _time(seconds: float) -> Any:
    sec, nanosec = divmod(ns(seconds), 1_000_000_000)
    return typestore().types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec)


def _header(seconds: float) -> Any:
    return typestore().types['std_msgs/msg/Header'](stamp=_time(seconds), frame_id='')


def _axis_state(s: AxisSnapshot) -> Any:
    emcy = s.last_emcy
    return typestore().types[AXIS_STATE](
        header=_header(s.stamp), joint_name=s.joint, node_id=s.node_id, axis=s.slot, available=s.available,
        nmt_state=str(s.nmt_state), drive_state=int(s.drive_state), drive_state_name=s.drive_state.label,
        state=int(s.state), state_name=s.state.label, mode=max(-128, min(127, s.mode)), mode_name=s.mode_name,
        statusword=s.statusword, controlword=s.controlword, fault=s.fault, warning=s.warning,
        target_reached=s.target_reached, internal_limit_active=s.internal_limit,
        following_error=s.following_error, halted=s.halted, command_stale=s.command_stale, message=s.message,
        last_error_code=emcy.code if emcy is not None else 0, last_error_text=emcy.text if emcy is not None else '')


def to_message(sample: Decoded, topics: Topics) -> tuple[str, str, int, Any]:
    """(topic, message type, log time in ns, message object) of one decoded sample."""
    types = typestore().types
    if isinstance(sample, JointSample):
        msg = types[JOINT_STATE](header=_header(sample.stamp), name=list(sample.names),
                                 position=np.array(sample.positions, dtype=np.float64),
                                 velocity=np.array(sample.velocities, dtype=np.float64),
                                 effort=np.array(sample.efforts, dtype=np.float64))
        return topics.joint_states, JOINT_STATE, ns(sample.stamp), msg
    if isinstance(sample, AxisStatesSample):
        msg = types[AXIS_STATES](header=_header(sample.stamp), axes=[_axis_state(s) for s in sample.axes])
        return topics.axis_states, AXIS_STATES, ns(sample.stamp), msg
    if isinstance(sample, EmcySample):
        e = sample.event
        msg = types[EMCY](header=_header(e.timestamp), node_id=e.node_id, node_name=e.node_name,
                          joint_name=sample.joint, error_code=e.code, error_register=e.register,
                          manufacturer_data=np.frombuffer(bytes(e.manufacturer[:5]).ljust(5, b'\0'), dtype=np.uint8),
                          text=e.text, register_text=e.register_text, severity=e.severity.value, reset=e.is_reset)
        return topics.emcy, EMCY, ns(e.timestamp), msg
    assert isinstance(sample, BusNotice)
    msg = types[LOG](stamp=_time(sample.timestamp), level=LOG_LEVEL[sample.level],
                     name=sample.node_name or 'bus', msg=sample.message, file='',
                     function=sample.kind, line=sample.node_id)
    return topics.bus_events, LOG, ns(sample.timestamp), msg


def to_cdr(sample: Decoded, topics: Topics) -> tuple[str, str, int, bytes]:
    """(topic, message type, log time in ns, CDR) of one decoded sample."""
    topic, msgtype, stamp, msg = to_message(sample, topics)
    return topic, msgtype, stamp, bytes(typestore().serialize_cdr(msg, msgtype))
