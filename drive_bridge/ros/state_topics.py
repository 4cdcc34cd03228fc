"""State the node publishes: joint states, axis states, EMCY, CAN frames, diagnostics.

Joint states are published from the bus client's state-lane thread as soon as the bus process
sends a cycle's state (once the drives' synchronous TPDOs answering a SYNC are all in, or at
the next SYNC when some did not come); EMCY and frames from its request-lane thread: rclpy's
publish is thread-safe and cheap (about 8 µs with no subscriber, docs/python-ecosystem.md §6).
Frames cross from the bus process only while ``~/can_frames`` has a subscriber (or a recording
runs).
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import can
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from drive_bridge_interfaces.msg import AxisStates, CanFrame, Emcy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from drive_bridge.busproc.client import BusClient
from drive_bridge.cia301.emcy import EmcyEvent, Severity
from drive_bridge.ros.conversions import axis_state_msg, emcy_msg
from drive_bridge.ros.diagnostics import diagnostics
from drive_bridge.ros.frames import stamp_from_seconds, to_frame_msg
from drive_bridge.ros.parameters import BridgeParameters


def safe_publish(node: Node, publisher: Any, msg: Any) -> bool:
    """Publish from one of the bus client's threads; False (nothing raised) once the node's
    context is shut down (a signal ends rclpy before the node is closed), so the last reports
    of a stopping bus process are dropped quietly instead of failing in every listener."""
    try:
        publisher.publish(msg)
    except Exception:
        if node.context.ok():
            raise
        return False
    return True


def state_qos(params: BridgeParameters) -> QoSProfile:
    reliability = (ReliabilityPolicy.BEST_EFFORT if params.qos_reliability == 'best_effort'
                   else ReliabilityPolicy.RELIABLE)
    return QoSProfile(depth=params.qos_depth, reliability=reliability)


class StateTopics:
    """Publishers of one bus node; :meth:`attach` starts feeding them from the master."""

    def __init__(self, node: Node, master: BusClient, params: BridgeParameters) -> None:
        self.node = node
        self.master = master
        self.params = params
        qos = state_qos(params)
        self.joint_states = node.create_publisher(JointState, params.joint_states_topic, qos)
        self.axis_states = node.create_publisher(AxisStates, '~/axis_states', qos)
        self.emcy = node.create_publisher(Emcy, '~/emcy', QoSProfile(depth=100))
        self.frames = node.create_publisher(CanFrame, '~/can_frames', QoSProfile(depth=1000))
        self.diagnostics = node.create_publisher(DiagnosticArray, '/diagnostics', QoSProfile(depth=10))
        self.joints = list(master.axes)
        self._channel = str(master.config.bus.channel)
        # node id -> axis slot -> joint (an EMCY names the slot; the config may list slots in any order)
        self._joint_of_node = {n.node_id: {a.slot: a.joint for a in n.config.axes} for n in master.nodes.values()}
        self._min_interval = 1.0 / params.publish_rate if params.publish_rate > 0 else 0.0
        self._last_joint_states = 0.0
        self._frame_subscribers = 0
        self._forwarding_frames = False
        self._last_states: tuple = ()
        self._unavailable: set[str] = set()
        self._seen: set[str] = set()  # joints published at least once
        # joint and axis states are published from the CAN, cycle, executor and timer threads
        self._states_lock = threading.RLock()
        self.active = False
        # the recorder's tee (topic, message) after each publish, and extra /diagnostics lines
        self.tee: Callable[[str, Any], None] | None = None
        self.diagnostic_sources: list[Callable[[], DiagnosticStatus]] = []

    def _publish(self, publisher: Any, msg: Any) -> None:
        if not safe_publish(self.node, publisher, msg):
            return
        tee = self.tee
        if tee is not None:
            tee(publisher.topic_name, msg)

    def attach(self) -> None:
        """Register with the bus client and start the timers."""
        self.master.add_feedback_listener(self.on_feedback)
        self.master.add_emcy_listener(self.on_emcy)
        self.node.create_timer(0.5, self._count_frame_subscribers)
        # always created (cancelled while state_rate is 0), so apply() can change the rates
        self._axis_timer = self.node.create_timer(1.0 / (self.params.state_rate or 1.0),
                                                  lambda: self.publish_axis_states(force=True))
        if not self.params.state_rate:
            self._axis_timer.cancel()
        self._diagnostics_timer = self.node.create_timer(self.params.diagnostics_period, self.publish_diagnostics)

    def apply(self, params: BridgeParameters) -> None:
        """The run-time parameters publish_rate, state_rate and diagnostics_period, at once."""
        self.params = params
        self._min_interval = 1.0 / params.publish_rate if params.publish_rate > 0 else 0.0
        if params.state_rate > 0:
            self._axis_timer.timer_period_ns = round(1e9 / params.state_rate)
            self._axis_timer.reset()
        else:
            self._axis_timer.cancel()
        self._diagnostics_timer.timer_period_ns = round(params.diagnostics_period * 1e9)
        self._diagnostics_timer.reset()

    # -- joint states (the bus client's state-lane thread) -------------------------------------------
    def on_feedback(self) -> None:
        self._publish_states()

    def on_bus_lost(self) -> None:
        """Every joint unavailable now: say so on ~/axis_states and /diagnostics at once."""
        self.publish_axis_states(force=True)
        self.publish_diagnostics()

    def _publish_states(self) -> None:
        if not self.active:
            return
        if not self._states_lock.acquire(blocking=False):
            return  # another thread (CAN, cycle, executor) publishes this cycle's states right now
        try:
            now = time.monotonic()
            if self._min_interval and now - self._last_joint_states < self._min_interval:
                return
            self._last_joint_states = now
            self.publish_joint_states()
            self.publish_axis_states(force=False)
        finally:
            self._states_lock.release()

    def publish_joint_states(self) -> None:
        """Available joints only: a joint whose drive is lost is left out (and reported on
        ~/axis_states and /diagnostics) instead of repeating a stale value."""
        with self._states_lock:
            self._publish_joint_states()

    def _publish_joint_states(self) -> None:
        msg = JointState()
        newest = 0.0
        unavailable = set()
        for joint in self.joints:
            available, position, velocity, effort, stamp = self.master.axes[joint].feedback()
            if not available:
                unavailable.add(joint)
                continue
            msg.name.append(joint)
            msg.position.append(position)
            msg.velocity.append(velocity)
            msg.effort.append(effort)
            newest = max(newest, stamp)
        lost = (unavailable - self._unavailable) & self._seen
        if lost:
            self.node.get_logger().error(
                f'joint(s) {", ".join(sorted(lost))} unavailable: left out of '
                f'{self.params.joint_states_topic} until their drive is back')
        self._unavailable = unavailable
        self._seen.update(msg.name)
        if not msg.name:
            return
        msg.header.stamp = stamp_from_seconds(newest) if newest else self.node.get_clock().now().to_msg()
        self._publish(self.joint_states, msg)

    def publish_axis_states(self, force: bool) -> None:
        """On every change of state, mode or flags; and at state_rate when forced."""
        if not self.active:
            return
        with self._states_lock:
            self._publish_axis_states(force)

    def _publish_axis_states(self, force: bool) -> None:
        key = tuple(self.master.axes[j].state_key() for j in self.joints)  # every cycle: no snapshots
        if not force and key == self._last_states:
            return
        self._last_states = key
        snapshots = [self.master.axes[j].snapshot() for j in self.joints]
        msg = AxisStates()
        msg.header.stamp = self.node.get_clock().now().to_msg()
        msg.axes = [axis_state_msg(s) for s in snapshots]
        self._publish(self.axis_states, msg)

    # -- EMCY and frames (CAN threads) -----------------------------------------------------------
    def on_emcy(self, event: EmcyEvent) -> None:
        joints = self._joint_of_node.get(event.node_id, {})
        if event.slot is not None:
            joint = joints.get(event.slot, '')
        else:
            joint = next(iter(joints.values())) if len(joints) == 1 else ''
        self._publish(self.emcy, emcy_msg(event, joint))
        # one call site per severity (rclpy), as the drive family reads the EMCY
        if event.is_reset or event.severity is Severity.INFO:
            self.node.get_logger().info(str(event))
        elif event.severity is Severity.WARNING:
            self.node.get_logger().warning(str(event))
        else:
            self.node.get_logger().error(str(event))

    def _count_frame_subscribers(self) -> None:
        """Frames cross from the bus process only while someone subscribes ~/can_frames."""
        self._frame_subscribers = self.frames.get_subscription_count()
        wanted = bool(self._frame_subscribers) and self.params.publish_frames
        if wanted and not self._forwarding_frames:
            self.master.add_frame_listener(self.on_frame)
        elif not wanted and self._forwarding_frames:
            self.master.remove_frame_listener(self.on_frame)
        self._forwarding_frames = wanted

    def on_frame(self, msg: can.Message) -> None:
        if self._frame_subscribers:
            safe_publish(self.node, self.frames, to_frame_msg(msg, self._channel))

    # -- diagnostics (executor) ------------------------------------------------------------------
    def publish_diagnostics(self) -> None:
        client = self.master
        boundary = {'bus_process': client.pid, 'frames_dropped_at_boundary': client.frame_drops,
                    'cyclic_states_dropped': client.state_drops, 'commands_coalesced': client.commands.coalesced}
        array = diagnostics(client.snapshot(), self.node.get_fully_qualified_name(), client.lost, boundary,
                            client.report_drops)
        array.status.extend(source() for source in self.diagnostic_sources)
        array.header.stamp = self.node.get_clock().now().to_msg()
        self._publish(self.diagnostics, array)
