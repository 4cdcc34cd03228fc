"""control_msgs' FollowJointTrajectory action on the bus's joints (MoveIt's controller type).

What the bridge cannot execute is refused first, with the reason (ros/goal_checks.py). A new
goal replaces the running one (which ends aborted, "replaced"); cancel stops the
joints with a controlled deceleration; a path tolerance violation stops and aborts; at
the end the goal tolerance must hold within goal_time_tolerance. Feedback (desired,
actual, error) is sent at FEEDBACK_PERIOD. The execute coroutine sleeps on rclpy futures
completed by timers, so the single-threaded executor keeps running.
"""
from __future__ import annotations

import math
import threading
import time

import rclpy.task
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from trajectory_msgs.msg import JointTrajectoryPoint

from drive_bridge.busproc.client import BusClient
from drive_bridge.busproc.executor import ExecutorProxy
from drive_bridge.busproc.proxies import HandleProxy
from drive_bridge.errors import RequestRefused
from drive_bridge.ros.callback_guard import failures_of, guard_execute, guard_goal
from drive_bridge.ros.command_topics import log_accepted
from drive_bridge.ros.conversions import seconds, trajectory_from_msg
from drive_bridge.ros.errors import GoalRefused, MessageTooLarge, NonFinite
from drive_bridge.ros.frames import stamp_from_seconds
from drive_bridge.ros.goal_checks import check_goal, tolerances
from drive_bridge.ros.message_checks import check_trajectory_points
from drive_bridge.ros.message_limits import check_trajectory_size
from drive_bridge.ros.pool import await_future
from drive_bridge.streaming.errors import TrajectoryError

FEEDBACK_PERIOD = 0.05
DEFAULT_SETTLE = 0.5  # s allowed after the end for the goal tolerance when goal_time_tolerance is 0
Result = FollowJointTrajectory.Result


class TrajectoryAction:
    def __init__(self, node: Node, master: BusClient, executor: ExecutorProxy) -> None:
        self.node = node
        self.master = master
        self.executor = executor
        self.active = True
        self._current: ServerGoalHandle | None = None
        failures = failures_of(node)
        self.server = ActionServer(node, FollowJointTrajectory, '~/follow_joint_trajectory',
                                   execute_callback=guard_execute(failures, self.execute,
                                                                  lambda text: self._result(Result.INVALID_GOAL, text)),
                                   goal_callback=guard_goal(failures, self.on_goal),
                                   cancel_callback=lambda _goal: CancelResponse.ACCEPT,
                                   callback_group=ReentrantCallbackGroup())

    def on_goal(self, _request) -> GoalResponse:
        return GoalResponse.ACCEPT if self.active else GoalResponse.REJECT

    async def _sleep(self, seconds_: float) -> None:
        future: rclpy.task.Future = rclpy.task.Future()
        executor = self.node.executor

        def done() -> None:
            future.set_result(None)
            if executor is not None:
                executor.wake()
        threading.Timer(seconds_, done).start()
        await future

    @staticmethod
    def _result(code: int, text: str) -> FollowJointTrajectory.Result:
        return FollowJointTrajectory.Result(error_code=code, error_string=text)

    async def execute(self, goal: ServerGoalHandle) -> FollowJointTrajectory.Result:
        request = goal.request
        try:  # before any per-point work
            check_trajectory_size(len(request.trajectory.joint_names), len(request.trajectory.points))
        except MessageTooLarge as exc:
            goal.abort()
            return self._result(Result.INVALID_GOAL, str(exc))
        try:
            check_goal(request, list(self.master.axes), Result.INVALID_GOAL, Result.INVALID_JOINTS)
            check_trajectory_points(request.trajectory.points)
        except GoalRefused as exc:
            goal.abort()
            return self._result(exc.code, str(exc))
        except NonFinite as exc:
            goal.abort()
            return self._result(Result.INVALID_GOAL, str(exc))
        joints = list(request.trajectory.joint_names)
        unknown = [j for j in joints if j not in self.master.axes]
        if unknown or not joints:
            goal.abort()
            text = f'unknown joint(s) {", ".join(unknown)}' if unknown else 'no joint_names'
            return self._result(Result.INVALID_JOINTS, text)
        try:  # validated in the bus process; the executor keeps spinning meanwhile
            handle = await await_future(self.node, self.executor.submit_async(
                trajectory_from_msg(request.trajectory), '~/follow_joint_trajectory'))
        except TrajectoryError as exc:
            goal.abort()
            code = Result.OLD_HEADER_TIMESTAMP if 'in the past' in str(exc) else Result.INVALID_GOAL
            return self._result(code, str(exc))
        except (RequestRefused, TimeoutError) as exc:
            goal.abort()
            return self._result(Result.INVALID_GOAL, str(exc))
        if handle is None:  # an empty trajectory: a stop request, done
            goal.succeed()
            return self._result(Result.SUCCESSFUL, 'empty trajectory: joints stopped')
        log_accepted(self.node, handle, len(request.trajectory.points))
        previous, self._current = self._current, goal
        if previous is not None and previous.is_active:
            self.node.get_logger().info('follow_joint_trajectory: a new goal replaces the running one')
        return await self._follow(goal, handle, joints)

    async def _follow(self, goal: ServerGoalHandle, handle: HandleProxy,
                      joints: list[str]) -> FollowJointTrajectory.Result:
        request = goal.request
        path = {f: tolerances(request.path_tolerance, joints, f) for f in ('position', 'velocity')}
        final = {f: tolerances(request.goal_tolerance, joints, f) for f in ('position', 'velocity')}
        settle = seconds(request.goal_time_tolerance) or DEFAULT_SETTLE
        last_point = request.trajectory.points[-1]
        goal_positions = dict(zip(joints, last_point.positions))
        while True:
            if goal.is_cancel_requested:
                self.executor.stop(joints, 'goal cancelled', smooth=True)
                goal.canceled()
                return self._result(Result.SUCCESSFUL, 'cancelled: joints stopped with a controlled deceleration')
            if not goal.is_active or handle.state == 'superseded':
                goal.abort()
                return self._result(Result.INVALID_GOAL, f'aborted: {handle.reason or "replaced by a newer goal"}')
            if handle.state in ('aborted', 'cancelled'):
                goal.abort()
                return self._result(Result.PATH_TOLERANCE_VIOLATED, f'aborted: {handle.reason}')
            now = self.executor.now()  # the stream clock (behind wall time after stalled cycles)
            feedback, errors = self._feedback(joints, now)
            goal.publish_feedback(feedback)
            if now < handle.end:
                violation = self._violation(errors, path, 'path')
                if violation:
                    self.executor.stop(joints, violation, 'aborted', smooth=True)
                    goal.abort()
                    return self._result(Result.PATH_TOLERANCE_VIOLATED, violation)
            else:
                actual = {j: self.master.axes[j].snapshot() for j in joints}
                # a velocity-only goal has no goal position: only its velocity tolerance applies
                misses = [f'{j}: position {actual[j].position:.6g}, goal {goal_positions[j]:.6g} '
                          f'(tolerance {tol:g})' for j, tol in final['position'].items()
                          if j in goal_positions and abs(actual[j].position - goal_positions[j]) > tol]
                misses += [f'{j}: velocity {actual[j].velocity:.6g} (tolerance {tol:g})'
                           for j, tol in final['velocity'].items() if abs(actual[j].velocity) > tol]
                if not misses:
                    goal.succeed()
                    return self._result(Result.SUCCESSFUL, '; '.join(handle.notes))
                if now > handle.end + settle:
                    goal.abort()
                    return self._result(Result.GOAL_TOLERANCE_VIOLATED,
                                        f'goal not reached {settle:g} s after the end: ' + '; '.join(misses))
            await self._sleep(FEEDBACK_PERIOD)

    def _feedback(self, joints: list[str], now: float):
        desired, actual, error = JointTrajectoryPoint(), JointTrajectoryPoint(), JointTrajectoryPoint()
        errors = {}
        for joint in joints:
            wanted = self.executor.desired(joint, now)
            snapshot = self.master.axes[joint].snapshot()
            d_pos = wanted.position if wanted else math.nan
            d_vel = wanted.velocity if wanted else math.nan
            desired.positions.append(d_pos)
            desired.velocities.append(d_vel)
            actual.positions.append(snapshot.position)
            actual.velocities.append(snapshot.velocity)
            error.positions.append(d_pos - snapshot.position)
            error.velocities.append(d_vel - snapshot.velocity)
            errors[joint] = (d_pos - snapshot.position, d_vel - snapshot.velocity)
        feedback = FollowJointTrajectory.Feedback(joint_names=joints, desired=desired, actual=actual, error=error)
        feedback.header.stamp = stamp_from_seconds(time.time())
        for point in (desired, actual, error):
            point.time_from_start = Duration()
        return feedback, errors

    @staticmethod
    def _violation(errors: dict[str, tuple[float, float]], tolerances: dict[str, dict[str, float]],
                   kind: str) -> str:
        for field, index in (('position', 0), ('velocity', 1)):
            for joint, tol in tolerances[field].items():
                value = errors[joint][index]
                if math.isfinite(value) and abs(value) > tol:
                    return f'{kind} tolerance violated: {joint} {field} error {value:.6g} > {tol:g}'
        return ''
