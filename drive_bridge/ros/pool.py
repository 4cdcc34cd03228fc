"""Blocking work (SDO, intents that wait for the drive) run from async service handlers on a
thread pool, so the executor keeps spinning while a drive answers.

The pool holds at most ``limit`` requests, running or waiting: any client may call the services
as often as it likes, and a plain ThreadPoolExecutor would queue its work without end. Beyond the
limit a request is refused at once (:class:`PoolBusy`), and the node keeps serving.
"""
from __future__ import annotations

import concurrent.futures
import threading
from collections.abc import Callable
from typing import Any, TypeVar

import rclpy.task
from rclpy.node import Node

from drive_bridge.ros.errors import PoolBusy

T = TypeVar('T')


class BoundedPool(concurrent.futures.ThreadPoolExecutor):
    """A thread pool that refuses work beyond ``limit`` items running or waiting."""

    def __init__(self, max_workers: int, limit: int, thread_name_prefix: str) -> None:
        super().__init__(max_workers=max_workers, thread_name_prefix=thread_name_prefix)
        self.limit = limit
        self._pending = 0
        self._count_lock = threading.Lock()

    @property
    def pending(self) -> int:
        return self._pending

    def submit(self, fn: Callable[..., T], /, *args: Any, **kwargs: Any) -> concurrent.futures.Future[T]:
        with self._count_lock:
            if self._pending >= self.limit:
                raise PoolBusy(f'busy: {self._pending} requests are already running or waiting for the bus '
                               f'(at most {self.limit}); nothing was sent, try again once they are answered')
            self._pending += 1
        try:
            future = super().submit(fn, *args, **kwargs)
        except BaseException:
            self._done()
            raise
        future.add_done_callback(lambda _future: self._done())
        return future

    def _done(self) -> None:
        with self._count_lock:
            self._pending -= 1


async def in_pool(node: Node, pool: concurrent.futures.ThreadPoolExecutor, work: Callable[[], T]) -> T:
    """Run ``work`` in ``pool`` and await its result (or exception) without blocking the
    node's executor; the executor is woken when the result is there. A full BoundedPool
    raises PoolBusy here, before anything runs."""
    future: rclpy.task.Future = rclpy.task.Future()

    def run() -> None:
        try:
            future.set_result(work())
        except BaseException as exc:  # delivered to the awaiting handler
            future.set_exception(exc)
        executor = node.executor
        if executor is not None:
            executor.wake()
    pool.submit(run)
    return await future  # type: ignore[no-any-return]


async def await_future(node: Node, future: concurrent.futures.Future[T]) -> T:
    """Await a concurrent future (e.g. an answer from the bus process) in a coroutine handler
    without blocking the node's executor, which is woken when the future is done."""
    awaited: rclpy.task.Future = rclpy.task.Future()

    def done(finished: concurrent.futures.Future[T]) -> None:
        error = finished.exception()
        if error is not None:
            awaited.set_exception(error)
        else:
            awaited.set_result(finished.result())
        executor = node.executor
        if executor is not None:
            executor.wake()
    future.add_done_callback(done)
    return await awaited  # type: ignore[no-any-return]
