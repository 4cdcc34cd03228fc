"""Commands from planners: JointTrajectory, Float64MultiArray (forward_command_controller)
and JointState (topic_based_ros2_control).

A message is checked whole before anything is applied: one bad joint refuses the whole
message, with the reason logged and published on ``~/command_errors``. The structure (joint
names, counts, numbers) is checked here; the bus process checks each joint's command against
its mode, state and limits and refuses the whole message there (reported back the same way).
Direct commands cross latest-value-wins, at most once per cycle per topic and joint set
(:mod:`drive_bridge.busproc.commands`): a flood of them never floods the bus process.
"""
from __future__ import annotations

import time

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory

from drive_bridge.busproc.client import BusClient
from drive_bridge.busproc.executor import ExecutorProxy
from drive_bridge.busproc.intents import JointCommand
from drive_bridge.busproc.proxies import HandleProxy
from drive_bridge.errors import RequestRefused
from drive_bridge.joint import JointError
from drive_bridge.joint.limits import limit_problem
from drive_bridge.master.events import BusEvent, EventKind
from drive_bridge.ros.conversions import finite_or_none, trajectory_from_msg
from drive_bridge.ros.errors import MalformedMessage, MessageTooLarge, NonFinite
from drive_bridge.ros.message_checks import check_joint_commands, check_trajectory_points
from drive_bridge.ros.message_limits import check_trajectory_bytes
from drive_bridge.ros.parameters import BridgeParameters
from drive_bridge.ros.state_topics import safe_publish
from drive_bridge.streaming.errors import TrajectoryError

LOG_INTERVAL = 1.0  # s between log lines for repeated command errors on one topic


def log_accepted(node: Node, handle: HandleProxy, points: int) -> None:
    """One line per accepted trajectory, with what planning changed; what it could not check
    (a joint without a velocity limit, naming the key) as a warning."""
    notes = ''.join(f'; {note}' for note in handle.notes)
    node.get_logger().info(f'trajectory {handle.id}: {points} point(s) for {", ".join(handle.joints)}, '
                           f'{handle.end - handle.start:.3f} s{notes}')
    for warning in handle.warnings:
        node.get_logger().warning(f'trajectory {handle.id}: {warning}')


class CommandTopics:
    """Subscriptions for commands; they act only while ``active``."""

    def __init__(self, node: Node, master: BusClient, executor: ExecutorProxy,
                 params: BridgeParameters) -> None:
        self.node = node
        self.master = master
        self.executor = executor
        self.params = params
        self.command_joints = list(params.command_joints) or list(master.axes)
        self.active = False
        self.errors = node.create_publisher(String, '~/command_errors', QoSProfile(depth=50))
        self._last_log: dict[str, float] = {}
        group = MutuallyExclusiveCallbackGroup()
        # raw: the size is checked before rclpy builds one Python object per point
        node.create_subscription(JointTrajectory, '~/joint_trajectory', self.on_trajectory, 10,
                                 callback_group=group, raw=True)
        node.create_subscription(Float64MultiArray, '~/commands', self.on_commands, 10, callback_group=group)
        node.create_subscription(JointState, params.joint_commands_topic, self.on_joint_commands,
                                 qos_profile_sensor_data, callback_group=group)
        unknown = [j for j in self.command_joints if j not in master.axes]
        if unknown:
            raise ValueError(f'parameter command_joints names unknown joint(s) {", ".join(unknown)}')
        master.add_refusal_listener(self.refuse)

    def refuse(self, topic: str, reason: str) -> None:
        text = f'{topic}: refused: {reason}'
        if not safe_publish(self.node, self.errors, String(data=text)):
            return
        now = time.monotonic()
        if now - self._last_log.get(topic, 0.0) >= LOG_INTERVAL:
            self._last_log[topic] = now
            self.node.get_logger().warning(text)

    def on_event(self, event: BusEvent) -> None:
        """A set-point the cycle refused (whatever produced it) is a refused command too."""
        if event.kind is EventKind.SETPOINT_REFUSED:
            self.errors.publish(String(data=f'cycle check: refused: {event.message}'))

    def _inactive(self, topic: str) -> bool:
        if self.master.lost:
            self.refuse(topic, self.master.lost)
            return True
        if not self.active:
            self.refuse(topic, 'the bridge is not active (deactivated or not configured)')
        return not self.active

    # -- JointTrajectory -----------------------------------------------------------------------
    def on_trajectory(self, raw: bytes) -> None:
        topic = '~/joint_trajectory'
        if self._inactive(topic):
            return
        try:
            check_trajectory_bytes(raw)
            msg = deserialize_message(raw, JointTrajectory)
        except (MessageTooLarge, MalformedMessage) as exc:
            self.refuse(topic, str(exc))
            return
        except Exception as exc:  # the middleware's own error for bytes it cannot read
            self.refuse(topic, str(MalformedMessage(f'not a trajectory_msgs/JointTrajectory: {exc}')))
            return
        try:
            check_trajectory_points(msg.points)
        except NonFinite as exc:
            self.refuse(topic, str(exc))
            return
        joints = list(msg.joint_names)
        unknown = [j for j in joints if j not in self.master.axes]
        if unknown:  # before the bus process spends any time on it
            self.refuse(topic, f'unknown joint(s) {", ".join(unknown)}; this bus has {", ".join(self.master.axes)}')
            return
        points = len(msg.points)
        future = self.executor.submit_async(trajectory_from_msg(msg), topic)
        future.add_done_callback(lambda done: self._submitted(topic, points, done))

    def _submitted(self, topic: str, points: int, future) -> None:
        """The bus process's answer to a trajectory (its request-lane thread)."""
        error = future.exception()
        if isinstance(error, (TrajectoryError, RequestRefused, TimeoutError)):
            self.refuse(topic, str(error).removeprefix(f'{topic}: '))
            return
        if error is not None:
            self.refuse(topic, f'{type(error).__name__}: {error}')
            return
        handle = future.result()
        if handle is not None:
            log_accepted(self.node, handle, points)

    # -- direct commands -------------------------------------------------------------------------
    def _apply(self, topic: str, commands: dict[str, dict[str, float | None]]) -> None:
        """Check every joint's command against its limits, then send all (or none); the bus
        process checks them again against each joint's mode and state."""
        try:
            for joint, command in commands.items():
                problem = limit_problem(self.master.axes[joint].config.limits, **command)
                if problem:
                    raise JointError(f'joint {joint}: {problem}')
        except JointError as exc:
            self.refuse(topic, str(exc))
            return
        self.master.commands.submit(topic, tuple(JointCommand(joint, **command) for joint, command in commands.items()))

    def on_commands(self, msg: Float64MultiArray) -> None:
        topic = '~/commands'
        if self._inactive(topic):
            return
        if len(msg.data) != len(self.command_joints):  # before any per-value work
            self.refuse(topic, f'{len(msg.data)} value(s) for {len(self.command_joints)} joint(s) '
                               f'({", ".join(self.command_joints)})')
            return
        values = list(msg.data)
        interface = self.params.command_interface
        self._apply(topic, {joint: {interface: value} for joint, value in zip(self.command_joints, values)})

    def on_joint_commands(self, msg: JointState) -> None:
        """Per joint, the field matching its mode: position, velocity or effort (NaN = none)."""
        topic = self.params.joint_commands_topic
        if self._inactive(topic):
            return
        if len(msg.name) > len(self.master.axes):  # before any per-name work
            self.refuse(topic, f'{len(msg.name)} names, more than the {len(self.master.axes)} joints of this bus')
            return
        unknown = [n for n in msg.name if n not in self.master.axes]
        if unknown:
            self.refuse(topic, f'unknown joint(s) {", ".join(unknown)}')
            return
        for field in ('position', 'velocity', 'effort'):
            values = getattr(msg, field)
            if values and len(values) != len(msg.name):
                self.refuse(topic, f'{len(values)} {field} value(s) for {len(msg.name)} name(s)')
                return
        try:
            check_joint_commands(msg.name, {f: getattr(msg, f) for f in ('position', 'velocity', 'effort')})
        except NonFinite as exc:
            self.refuse(topic, str(exc))
            return
        commands: dict[str, dict[str, float | None]] = {}
        for i, joint in enumerate(msg.name):
            wanted = self.master.axes[joint].command_field()
            value = finite_or_none(getattr(msg, wanted), i) if wanted else None
            if value is not None and wanted:
                commands[joint] = {wanted: value}
        if commands:
            self._apply(topic, commands)
