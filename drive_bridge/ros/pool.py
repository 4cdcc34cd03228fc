"""Blocking work (SDO, intents that wait for the drive) run from async service handlers on a
thread pool, so the executor keeps spinning while a drive answers."""
from __future__ import annotations

import concurrent.futures
from collections.abc import Callable
from typing import TypeVar

import rclpy.task
from rclpy.node import Node

T = TypeVar('T')


async def in_pool(node: Node, pool: concurrent.futures.ThreadPoolExecutor, work: Callable[[], T]) -> T:
    """Run ``work`` in ``pool`` and await its result (or exception) without blocking the
    node's executor; the executor is woken when the result is there."""
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
