"""A bus node under test with its watchers: the node (BusNode on a private rclpy context, its
simulated drives in the test's process: bridgetools), a frame recorder on its local bus (from
before the bridge starts), and recorders of /joint_states, ~/axis_states, ~/emcy,
~/command_errors; publishers for ~/commands and ~/joint_trajectory; service and state helpers.
Family ROS tests build one from their config data."""
from __future__ import annotations

import time
from typing import Any

from builtin_interfaces.msg import Duration
from drive_bridge_interfaces.msg import AxisState, AxisStates, Emcy
from drive_bridge_interfaces.srv import AxisCommand
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from akdtools import Sniffer
from bridgetools import local_data, start_bridge, stop_bridge
from rostools import RosHarness, wait_for

NS = '/drive_bridge'


def point(t: float, positions: list[float], velocities: list[float] | None = None,
          accelerations: list[float] | None = None) -> JointTrajectoryPoint:
    """A trajectory point at ``t`` s."""
    return JointTrajectoryPoint(positions=positions, velocities=velocities or [], accelerations=accelerations or [],
                                time_from_start=Duration(sec=int(t), nanosec=round((t % 1) * 1e9)))


class NodeBench:
    """The bus node, a frame recorder and topic recorders; waits until every joint publishes."""

    def __init__(self, ros: RosHarness, data: dict[str, Any], joints: tuple[str, ...],
                 parameters: list[Parameter] | None = None, call_timeout: float = 15.0) -> None:
        self.ros = ros
        self.call_timeout = call_timeout
        data = local_data(data)
        self.sniffer = Sniffer(data['bus']['channel'], interface='local')
        try:
            self.node = start_bridge(ros, data, parameters or [])
        except Exception:
            self.sniffer.close()
            raise
        self.states: list[JointState] = []
        self.axis_states: list[AxisStates] = []
        self.emcys: list[Emcy] = []
        self.errors: list[String] = []
        watcher = ros.node(f'watch_{time.monotonic_ns() % 1000000}')
        watcher.create_subscription(JointState, '/joint_states', self.states.append, 100)
        watcher.create_subscription(AxisStates, f'{NS}/axis_states', self.axis_states.append, 100)
        watcher.create_subscription(Emcy, f'{NS}/emcy', self.emcys.append, 100)
        watcher.create_subscription(String, f'{NS}/command_errors', self.errors.append, 100)
        self.commands = watcher.create_publisher(Float64MultiArray, f'{NS}/commands', 10)
        self.trajectories = watcher.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
        self.watcher = watcher
        self.node.master.wait_until_operational(15.0)
        wait_for(lambda: any(set(joints) <= set(m.name) for m in self.states), 10, 'every joint in /joint_states')

    def drive(self, node: int) -> Any:
        return self.node.simulation.drive(node)

    def call(self, srv_type: Any, name: str, **fields: Any) -> Any:
        client = self.watcher.create_client(srv_type, f'{NS}/{name}')
        return self.ros.call(client, srv_type.Request(**fields), timeout=self.call_timeout)

    def axis(self, name: str, *joints: str, **fields: Any) -> Any:
        return self.call(AxisCommand, name, joints=list(joints), **fields)

    def axis_state(self, joint: str) -> AxisState | None:
        for msg in reversed(self.axis_states):
            for state in msg.axes:
                if state.joint_name == joint:
                    return state
        return None

    def position(self, joint: str) -> float:
        msg = next(m for m in reversed(self.states) if joint in m.name)
        return float(dict(zip(msg.name, msg.position))[joint])

    def close(self) -> None:
        try:
            stop_bridge(self.node)
        finally:
            self.sniffer.close()
