"""One place around every ROS callback of the bus node: an unexpected exception in a
subscription, service, timer, parameter or action callback becomes a logged, refused request,
and the node keeps running (rclpy would let it leave ``executor.spin()`` and end the process).

:class:`GuardedCallbacks` is mixed into the node classes: it wraps what ``create_subscription``,
``create_service``, ``create_timer`` and the parameter callback hooks are given, so no call site
has to remember. The action server takes its callbacks directly: :func:`guard_execute` and
:func:`guard_goal` wrap those. Expected refusals (bad input) never get here: they are answered
where they are checked; this is the net under the bugs.
"""
from __future__ import annotations

import functools
import inspect
import time
import traceback
from collections.abc import Callable, Sequence
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.action import GoalResponse

LOG_INTERVAL = 1.0  # s between two tracebacks of the same callback


class CallbackFailures:
    """Counts and logs the failures of each callback (a traceback at most every LOG_INTERVAL)."""

    def __init__(self, node: Any) -> None:
        self.node = node
        self.count = 0
        self._logged: dict[str, float] = {}
        self.refuse: Callable[[str, str], None] | None = None  # (where, text): e.g. ~/command_errors

    def report(self, where: str, exc: BaseException) -> str:
        self.count += 1
        text = f'{where}: refused: unexpected error {exc!r} (the node keeps running)'
        now = time.monotonic()
        if now - self._logged.get(where, -LOG_INTERVAL) >= LOG_INTERVAL:
            self._logged[where] = now
            self.node.get_logger().error(f'{text}\n{"".join(traceback.format_exception(exc)).rstrip()}')
        return text


def _refused_response(response: Any, text: str) -> Any:
    for name, value in (('success', False), ('message', text)):
        if hasattr(response, name):
            setattr(response, name, value)
    return response


def guard_service(failures: CallbackFailures, name: str, callback: Callable[..., Any]) -> Callable[..., Any]:
    if inspect.iscoroutinefunction(callback):
        @functools.wraps(callback)
        async def async_service(request: Any, response: Any) -> Any:
            try:
                return await callback(request, response)
            except Exception as exc:
                return _refused_response(response, failures.report(name, exc))
        return async_service

    @functools.wraps(callback)
    def service(request: Any, response: Any) -> Any:
        try:
            return callback(request, response)
        except Exception as exc:
            return _refused_response(response, failures.report(name, exc))
    return service


def guard_plain(failures: CallbackFailures, name: str, callback: Callable[..., Any],
                refuse: bool = False) -> Callable[..., Any]:
    """A subscription or timer callback (``refuse``: also tell the refusal hook)."""
    @functools.wraps(callback)
    def plain(*args: Any) -> Any:
        try:
            return callback(*args)
        except Exception as exc:
            failures.report(name, exc)
            if refuse and failures.refuse is not None:
                failures.refuse(name, f'unexpected error {exc!r} (the node keeps running)')
            return None
    return plain


def guard_on_set(failures: CallbackFailures, callback: Callable[[Sequence[Any]], SetParametersResult]
                 ) -> Callable[[Sequence[Any]], SetParametersResult]:
    @functools.wraps(callback)
    def on_set(parameters: Sequence[Any]) -> SetParametersResult:
        try:
            return callback(parameters)
        except Exception as exc:
            names = ', '.join(getattr(p, 'name', '?') for p in parameters)
            return SetParametersResult(successful=False, reason=failures.report(f'set_parameters {names}', exc))
    return on_set


def guard_goal(failures: CallbackFailures, callback: Callable[[Any], GoalResponse]) -> Callable[[Any], GoalResponse]:
    @functools.wraps(callback)
    def on_goal(request: Any) -> GoalResponse:
        try:
            return callback(request)
        except Exception as exc:
            failures.report('follow_joint_trajectory goal', exc)
            return GoalResponse.REJECT
    return on_goal


def guard_execute(failures: CallbackFailures, callback: Callable[[Any], Any],
                  result: Callable[[str], Any]) -> Callable[[Any], Any]:
    """The action's execute coroutine: an exception aborts the goal with ``result(text)``."""
    @functools.wraps(callback)
    async def execute(goal: Any) -> Any:
        try:
            return await callback(goal)
        except Exception as exc:
            text = failures.report('follow_joint_trajectory', exc)
            try:
                if goal.is_active:
                    goal.abort()
            except Exception:  # the goal may be in a state that takes no abort; the result says it
                pass
            return result(text)
    return execute


def _named(result: SetParametersResult, parameters: Sequence[Any]) -> SetParametersResult:
    """A refusal that does not name its parameter (rclpy's own: a wrong type) gets the name."""
    names = [getattr(p, 'name', '') for p in parameters]
    if not result.successful and not any(name and name in result.reason for name in names):
        result.reason = f'parameter {", ".join(names)}: {result.reason}'
    return result


def failures_of(node: Any) -> CallbackFailures:
    """The node's failure record (made on first use)."""
    failures = node.__dict__.get('callback_failures')
    if failures is None:
        failures = node.__dict__['callback_failures'] = CallbackFailures(node)
    return failures  # type: ignore[no-any-return]


class GuardedCallbacks:
    """Mixin for rclpy nodes: every callback handed to the node is guarded (see module doc)."""

    def _failures(self) -> CallbackFailures:
        return failures_of(self)

    def create_subscription(self, msg_type: Any, topic: str, callback: Callable[..., Any], *args: Any,
                            **kwargs: Any) -> Any:
        return super().create_subscription(  # type: ignore[misc]
            msg_type, topic, guard_plain(self._failures(), topic, callback, refuse=True), *args, **kwargs)

    def create_service(self, srv_type: Any, srv_name: str, callback: Callable[..., Any], *args: Any,
                       **kwargs: Any) -> Any:
        return super().create_service(  # type: ignore[misc]
            srv_type, srv_name, guard_service(self._failures(), srv_name, callback), *args, **kwargs)

    def create_timer(self, timer_period_sec: float, callback: Callable[..., Any] | None, *args: Any,
                     **kwargs: Any) -> Any:
        wrapped = guard_plain(self._failures(), 'timer', callback) if callback is not None else None
        return super().create_timer(timer_period_sec, wrapped, *args, **kwargs)  # type: ignore[misc]

    def set_parameters(self, parameter_list: Sequence[Any]) -> list[SetParametersResult]:
        results = super().set_parameters(parameter_list)  # type: ignore[misc]
        return [_named(result, [parameter]) for result, parameter in zip(results, parameter_list)]

    def set_parameters_atomically(self, parameter_list: Sequence[Any]) -> SetParametersResult:
        return _named(super().set_parameters_atomically(parameter_list), parameter_list)  # type: ignore[misc]

    def add_on_set_parameters_callback(self, callback: Callable[..., Any]) -> None:
        super().add_on_set_parameters_callback(guard_on_set(self._failures(), callback))  # type: ignore[misc]

    def add_post_set_parameters_callback(self, callback: Callable[..., Any]) -> None:
        super().add_post_set_parameters_callback(  # type: ignore[misc]
            guard_plain(self._failures(), 'post set_parameters', callback))
