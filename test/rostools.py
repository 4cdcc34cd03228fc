"""Helpers for tests that use rclpy: a private context spun in a background thread."""
from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

T = TypeVar('T')


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


def wait_for(check: Callable[[], T | None], timeout: float, what: str) -> T:
    """Poll ``check`` until it returns something truthy."""
    deadline = time.monotonic() + timeout
    while True:
        value = check()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f'timed out after {timeout} s waiting for {what}')
        time.sleep(0.01)


@contextmanager
def ros_harness() -> Iterator[RosHarness]:
    harness = RosHarness()
    try:
        yield harness
    finally:
        harness.shutdown()


SHM = Path('/dev/shm')


def remove_stale_dds_segments() -> int:
    """Delete Fast DDS shared-memory files (``/dev/shm/fastrtps_*``, ``sem.fastrtps_*``) that no
    live process maps or holds open: what killed processes left. Returns how many were removed."""
    if not SHM.is_dir():
        return 0
    mapped: set[str] = set()  # mapped or held open (a lock file) by some live process
    for proc in Path('/proc').glob('[0-9]*'):
        try:
            mapped.update(line.rsplit(' ', 1)[-1].strip() for line in (proc / 'maps').read_text().splitlines()
                          if '/dev/shm/' in line)
            for fd in (proc / 'fd').iterdir():
                target = os.readlink(fd)
                if target.startswith('/dev/shm/'):
                    mapped.add(target)
        except OSError:  # the process ended meanwhile, or is not ours
            continue
    removed = 0
    for path in SHM.iterdir():
        if path.name.startswith(('fastrtps_', 'sem.fastrtps_')) and str(path) not in mapped:
            try:
                path.unlink()
                removed += 1
            except OSError:
                pass
    return removed


def interrupt(proc: subprocess.Popen, timeout: float = 20.0) -> str:
    """Ctrl-C to a process started with ``start_new_session`` (its whole group), SIGKILL if it
    has not ended within ``timeout``; returns what it printed."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
    try:
        return proc.communicate(timeout=timeout)[0] or ''
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return proc.communicate()[0] or ''
