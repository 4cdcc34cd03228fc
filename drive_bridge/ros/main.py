"""Spinning a bus node (plain or lifecycle) until Ctrl-C: what the console entry points run."""
from __future__ import annotations

import gc

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from drive_bridge.ros.bridge import StartupError
from drive_bridge.ros.lifecycle import BusLifecycleNode
from drive_bridge.ros.node import BusNode


def run(config_path: str, args: list[str], managed: bool = False) -> int:
    """Spin a bus node (or its lifecycle variant) until Ctrl-C; returns the exit code."""
    rclpy.init(args=args)
    try:
        node: BusNode | BusLifecycleNode = BusLifecycleNode(config_path) if managed else BusNode(config_path)
    except StartupError as exc:
        rclpy.logging.get_logger('drive_bridge').fatal(str(exc))
        rclpy.try_shutdown()
        return 2
    # Start-up objects never become garbage: keep full collections from walking them, which
    # would stall the SYNC cycle thread (the GIL is held while the collector runs).
    gc.collect()
    gc.freeze()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
