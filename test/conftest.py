"""Test session set-up: DDS on loopback, a ROS domain of this run's own, and no stale Fast DDS
shared memory left by the processes the tests kill."""
from __future__ import annotations

import itertools
import os
import re
from pathlib import Path

# Set before anything imports rclpy: the RMW reads these at rclpy.init().
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
if 'ROS_DOMAIN_ID' not in os.environ:  # a domain no other test session on this machine holds
    from ddstools import claim_domain
    os.environ['ROS_DOMAIN_ID'] = str(claim_domain())
# the bus processes the tests start honour the test hook InjectSetpoint (drive_bridge.busproc.intents)
os.environ['DRIVE_BRIDGE_TEST_HOOKS'] = '1'

from typing import TYPE_CHECKING  # noqa: E402

import pytest  # noqa: E402
from _pytest.mark.expression import Expression  # noqa: E402

from ddstools import remove_stale_dds_segments  # noqa: E402
from markertools import module_kinds  # noqa: E402

if TYPE_CHECKING:
    from rostools import RosHarness


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    """Under ``-m "not ros"`` a module that imports ROS is not even imported: the core tests run
    without rclpy (``make test-fast``). Skipped only when no test of it can match, whatever
    other markers its tests carry."""
    markexpr = config.getoption('markexpr', '')
    if not markexpr or collection_path.suffix != '.py' or not collection_path.name.startswith('test_'):
        return None
    if 'ros' not in module_kinds(collection_path):
        return None
    expression = Expression.compile(markexpr)
    others = sorted(set(re.findall(r'[A-Za-z_]\w*', markexpr)) - {'and', 'or', 'not', 'ros'})
    for values in itertools.product((False, True), repeat=len(others)):
        marks = {'ros', *(name for name, on in zip(others, values) if on)}
        if expression.evaluate(lambda name, **_: name in marks):
            return None
    return True


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark each test ``ros`` / ``sim`` by what it uses (markertools); ``slow`` is explicit."""
    for item in items:
        kinds = module_kinds(Path(str(item.fspath)))
        if 'ros' in kinds or 'ros' in getattr(item, 'fixturenames', ()):
            item.add_marker(pytest.mark.ros)
        if 'sim' in kinds:
            item.add_marker(pytest.mark.sim)


@pytest.fixture
def ros() -> RosHarness:
    """A private rclpy context with a spinning executor, shut down after the test (rclpy is
    imported here, not at the top: the core tests run without it)."""
    from rostools import ros_harness
    with ros_harness() as harness:
        yield harness


@pytest.fixture(autouse=True)
def _no_stale_dds_segments():
    """Remove Fast DDS shared-memory segments no live process maps before each test. Tests
    SIGKILL bridge and simulator processes on purpose, which leaves their segments in /dev/shm;
    with hundreds of them a process discovering a new participant stalled for about 0.4 s and
    the demo's drives faulted by their heartbeat consumer (measured: the README example test
    failed 5 of 6 runs with 744 stale segments, 0 of 6 without them)."""
    remove_stale_dds_segments()


@pytest.fixture(autouse=True)
def _settled_garbage_collector():
    """Start every test with the earlier tests' objects frozen out of the collector, so a
    full collection does not stall the bridge's cycle thread for a long pytest session's
    worth of objects (the bridge's own process does the same after start-up)."""
    import gc
    gc.collect()
    gc.freeze()
    yield
