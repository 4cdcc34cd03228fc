"""Spinning a bus node (plain or lifecycle) until Ctrl-C, or until its bus process is lost:
what the console entry points run."""
from __future__ import annotations

import gc
import os
import time

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from drive_bridge.ros.errors import StartupError
from drive_bridge.ros.lifecycle import BusLifecycleNode
from drive_bridge.ros.node import BusNode


def lower_priority(increment: int) -> None:
    """Once the bus process runs: this (node) process yields the CPU to it (nice + increment), so
    the SYNC cycle runs first when a client floods the node. On Linux the nice value is a
    thread's: every thread of this process is lowered (DDS's, rclpy's, the bus client's readers),
    and threads started later inherit it. The bus process keeps its own priority (it was
    started before). Applied once per process."""
    global _reniced
    if increment <= 0 or _reniced:
        return
    _reniced = True
    failed = []
    for task in os.listdir('/proc/self/task') if os.path.isdir('/proc/self/task') else [str(os.getpid())]:
        try:
            tid = int(task)
            os.setpriority(os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + increment))
        except (OSError, ValueError) as exc:  # a thread that ended meanwhile, or not allowed
            failed.append(f'{task}: {exc}')
    if failed:
        rclpy.logging.get_logger('drive_bridge').warning(f'node_nice {increment}: {"; ".join(failed[:3])}')


_reniced = False
EXIT_BUS_LOST = 3  # the bus process ended without being asked (killed, crashed)
BUS_LOST_LINGER = 1.0  # s the node keeps answering (refusing, with the reason) before it exits


def run(config_path: str, args: list[str], managed: bool = False) -> int:
    """Spin a bus node (or its lifecycle variant) until Ctrl-C (exit 0) or until its bus
    process is lost (exit 3); a node that cannot start exits 2. An unhandled exception while
    it spins is raised after the node has abandoned its bus process (a node loss for it)."""
    rclpy.init(args=args)
    try:
        node: BusNode | BusLifecycleNode = BusLifecycleNode(config_path) if managed else BusNode(config_path)
    except StartupError as exc:
        rclpy.logging.get_logger('drive_bridge').fatal(str(exc))
        rclpy.try_shutdown()
        return 2
    if isinstance(node, BusLifecycleNode):  # its bus process starts at configure
        node.on_bus_started = lower_priority
    else:
        lower_priority(node.params.node_nice)
    # Start-up objects never become garbage: keep full collections from walking them.
    gc.collect()
    gc.freeze()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    code = 0
    lost_at = 0.0
    try:
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
            bridge = node.bridge
            if bridge is not None and bridge.bus_lost.is_set():
                lost_at = lost_at or time.monotonic()
                if time.monotonic() - lost_at >= BUS_LOST_LINGER:  # /diagnostics said it; refusals named it
                    code = EXIT_BUS_LOST
                    break
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:  # unhandled (the callbacks are guarded: rclpy's own): this process dies
        node.abandon()  # its bus process stops the axes as for a lost node, not as asked to end
        raise
    finally:
        node.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return code
