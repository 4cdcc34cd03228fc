"""Test session set-up: DDS on loopback, and a ROS domain of this run's own."""
from __future__ import annotations

import os

# Set before anything imports rclpy: the RMW reads these at rclpy.init().
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(1 + os.getpid() % 100))

import pytest  # noqa: E402

from rostools import RosHarness, ros_harness  # noqa: E402


@pytest.fixture
def ros() -> RosHarness:
    """A private rclpy context with a spinning executor, shut down after the test."""
    with ros_harness() as harness:
        yield harness


@pytest.fixture(autouse=True)
def _settled_garbage_collector():
    """Start every test with the earlier tests' objects frozen out of the collector, so a
    full collection does not stall the bridge's cycle thread for a long pytest session's
    worth of objects (the bridge's own process does the same after start-up)."""
    import gc
    gc.collect()
    gc.freeze()
    yield
