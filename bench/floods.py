"""``bench ros_cycle --floods``: what one hostile ROS client can do to the cycle.

A flood process of its own runs beside the bridge (and, for the ratio, beside the ``core``
variant: the same process, so the flood's own CPU counts on both sides) for the whole
measurement window, while trajectories stream on every axis:

- ``commands``: ``~/commands`` at 10 kHz (values NaN: refused by the node, for every message);
- ``services``: 20 clients calling ``~/sdo_read`` and ``~/param_read`` back to back;
- ``trajectories``: maximal ``JointTrajectory`` messages (5,000 points, joints the bus does not
  have) as fast as they go out;
- ``goal``: FollowJointTrajectory goals of 100,000 points, one after the other;
- ``parameters``: ``set_parameters`` with bad values (1e-300, NaN, inf, 1e12, -1) back to back.
"""
from __future__ import annotations

import math
import os
import sys
import threading
import time
from typing import Any

FLOODS = ('commands', 'services', 'trajectories', 'goal', 'parameters')
NS = '/drive_bridge'
COMMAND_RATE = 10_000.0  # Hz
SERVICE_CLIENTS = 20
BIG_POINTS = 5000
GOAL_POINTS = 100_000
BAD_VALUES = (1e-300, math.nan, math.inf, 1e12, -1.0, 0.0)


def flood_role(kind: str, joints: int, seconds: float) -> None:
    """Run one flood for ``seconds`` (its own rclpy node); print 'flooding' once it runs."""
    import rclpy
    from rclpy.executors import MultiThreadedExecutor
    rclpy.init()
    node = rclpy.create_node(f'bench_flood_{kind}')
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()
    end = time.monotonic() + seconds
    print('flooding', flush=True)
    {'commands': _commands, 'services': _services, 'trajectories': _trajectories, 'goal': _goal,
     'parameters': _parameters}[kind](node, joints, end)
    sys.stdout.flush()
    os._exit(0)  # rclpy's teardown under a spinning executor aborts the process: not what is measured


def _commands(node: Any, joints: int, end: float) -> None:
    from std_msgs.msg import Float64MultiArray
    publisher = node.create_publisher(Float64MultiArray, f'{NS}/commands', 10)
    msg = Float64MultiArray(data=[math.nan] * joints)
    period = 1.0 / COMMAND_RATE
    deadline = time.perf_counter()
    while time.monotonic() < end:
        publisher.publish(msg)
        deadline += period
        delay = deadline - time.perf_counter()
        if delay > 0:
            time.sleep(delay)


def _services(node: Any, joints: int, end: float) -> None:
    from drive_bridge_interfaces.srv import ParamRead, SdoRead

    def client(k: int) -> None:
        if k % 2:
            srv, name, request = ParamRead, 'param_read', ParamRead.Request(joint='j1', parameter='x')
        else:
            srv, name, request = SdoRead, 'sdo_read', SdoRead.Request(node_id=1, index=0x6041, subindex=0)
        cli = node.create_client(srv, f'{NS}/{name}')
        while time.monotonic() < end:
            if not cli.service_is_ready():
                time.sleep(0.05)
                continue
            future = cli.call_async(request)
            while not future.done() and time.monotonic() < end:
                time.sleep(0.0005)
    threads = [threading.Thread(target=client, args=(k,), daemon=True) for k in range(SERVICE_CLIENTS)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()


def _big_trajectory(points: int, joints: int) -> Any:
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    names = [f'not_on_this_bus_{k}' for k in range(joints)]
    msg = JointTrajectory(joint_names=names)
    msg.points = [JointTrajectoryPoint(positions=[0.0] * joints, velocities=[0.0] * joints,
                                       accelerations=[0.0] * joints,
                                       time_from_start=Duration(sec=n // 100, nanosec=(n % 100) * 10_000_000))
                  for n in range(1, points + 1)]
    return msg


def _trajectories(node: Any, joints: int, end: float) -> None:
    from trajectory_msgs.msg import JointTrajectory
    publisher = node.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
    msg = _big_trajectory(BIG_POINTS, joints)
    while time.monotonic() < end:
        publisher.publish(msg)


def _goal(node: Any, joints: int, end: float) -> None:
    from control_msgs.action import FollowJointTrajectory
    from rclpy.action import ActionClient
    client = ActionClient(node, FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
    client.wait_for_server(timeout_sec=10)
    goal = FollowJointTrajectory.Goal()
    goal.trajectory = _big_trajectory(GOAL_POINTS, joints)
    goal.trajectory.joint_names = [f'j{k}' for k in range(1, joints + 1)]
    while time.monotonic() < end:
        sent = client.send_goal_async(goal)
        while not sent.done() and time.monotonic() < end:
            time.sleep(0.01)
        if sent.done() and sent.result() is not None and sent.result().accepted:
            result = sent.result().get_result_async()
            while not result.done() and time.monotonic() < end:
                time.sleep(0.01)


def _parameters(node: Any, joints: int, end: float) -> None:
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    client = node.create_client(SetParameters, f'{NS}/set_parameters')
    names = ('state_rate', 'diagnostics_period', 'publish_rate', 'pvt_segment', 'pvt_lookahead')
    k = 0
    while time.monotonic() < end:
        if not client.service_is_ready():
            time.sleep(0.05)
            continue
        value = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=BAD_VALUES[k % len(BAD_VALUES)])
        request = SetParameters.Request(parameters=[Parameter(name=names[k % len(names)], value=value)])
        future = client.call_async(request)
        while not future.done() and time.monotonic() < end:
            time.sleep(0.0005)
        k += 1
