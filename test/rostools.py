"""Helpers for tests that use rclpy: a private context spun in a background thread."""
from __future__ import annotations

import os
import signal
import subprocess
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import rclpy
from rclpy.action import ActionClient as RclpyActionClient
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from waittools import wait_for

__all__ = ['RosHarness', 'ros_harness', 'wait_for']


class ActionClient(RclpyActionClient):  # type: ignore[misc]
    """rclpy's action client without its race (rclpy 7.1.5 from PyPI; ros2/rclpy#1123, fixed
    upstream by #1308 and its Jazzy backport #1519): a request is sent, then its sequence number
    registered, while the harness's executor thread may already take the answer; that answer is
    "unexpected", logged as "there may be more than one action server", and the goal's future
    never completes (a CI run: "timed out waiting for goal response", the bridge had accepted
    it). Sending and registering hold one lock, and so does taking the answers."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._request_lock = threading.RLock()

    def send_goal_async(self, *args: Any, **kwargs: Any) -> Any:
        with self._request_lock:
            return super().send_goal_async(*args, **kwargs)

    def _cancel_goal_async(self, *args: Any, **kwargs: Any) -> Any:
        with self._request_lock:
            return super()._cancel_goal_async(*args, **kwargs)

    def _get_result_async(self, *args: Any, **kwargs: Any) -> Any:
        with self._request_lock:
            return super()._get_result_async(*args, **kwargs)

    def take_data(self) -> Any:
        with self._request_lock:
            return super().take_data()


class RosHarness:
    """An rclpy context with an executor thread; nodes added to it are spun."""

    def __init__(self) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception:  # shutdown races end the loop
                if not self.context.ok():
                    return
                raise

    def node(self, name: str, **kwargs: Any) -> Node:
        node = Node(name, context=self.context, **kwargs)
        self.executor.add_node(node)
        return node

    def add(self, node: Node) -> Node:
        self.executor.add_node(node)
        return node

    def call(self, client: Any, request: Any, timeout: float = 10.0) -> Any:
        """Call a service and wait for the response; fails the test on timeout."""
        assert client.wait_for_service(timeout_sec=timeout), f'service {client.srv_name} not available'
        future = client.call_async(request)
        return wait_for(lambda: future.result() if future.done() else None, timeout,
                        f'no response from {client.srv_name}')

    def shutdown(self) -> None:
        for node in list(self.executor.get_nodes()):
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()
        rclpy.shutdown(context=self.context)
        self._thread.join(timeout=5)


@contextmanager
def ros_harness() -> Iterator[RosHarness]:
    harness = RosHarness()
    try:
        yield harness
    finally:
        harness.shutdown()


def spawn(args: list[str], log: Path, **kwargs: Any) -> subprocess.Popen:
    """Start a child whose output (stdout and stderr) goes to the file ``log``, not to a pipe: a
    pipe that nobody reads while the test runs fills at 64 KiB, and the child then blocks at its
    next log line (its executor stops answering; a busy machine logs more)."""
    with open(log, 'w') as out:
        proc = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, text=True, **kwargs)
    proc.log_path = log  # type: ignore[attr-defined]
    return proc


def output(proc: subprocess.Popen) -> str:
    """What a child started by ``spawn`` has printed so far."""
    log = getattr(proc, 'log_path', None)
    return log.read_text(errors='replace') if log is not None else ''


def interrupt(proc: subprocess.Popen, timeout: float = 20.0) -> str:
    """Ctrl-C to a process started with ``start_new_session`` (its whole group), SIGKILL if it
    has not ended within ``timeout``; returns what it printed."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
    try:
        return proc.communicate(timeout=timeout)[0] or output(proc)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return proc.communicate()[0] or output(proc)
