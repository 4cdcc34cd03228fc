"""Resource bounds of the ROS layer: the service pool refuses work beyond its limit, and a long
run of client requests, parameter sets and EMCY frames leaves no growth behind (threads, RSS,
pending work, the master's event and EMCY histories).
"""
from __future__ import annotations

import threading
import time
from typing import Any

import can
import psutil
import pytest
from drive_bridge_interfaces.msg import SdoValue
from drive_bridge_interfaces.srv import SdoRead, SdoWrite
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter

from bridgetools import node_snapshot, sniffing, start_bridge, stop_bridge
from bustools import demo_data
from drive_bridge.master.node import EMCY_HISTORY
from drive_bridge.ros.errors import PoolBusy
from drive_bridge.ros.pool import BoundedPool
from drive_bridge.ros.services import MAX_PENDING_REQUESTS, SERVICE_WORKERS
from rostools import RosHarness, wait_for

EVENT_HISTORY = 200  # the master keeps its 200 most recent events


def test_bounded_pool_refuses_beyond_its_limit_and_recovers() -> None:
    pool = BoundedPool(2, 4, 'bounds-test')
    release = threading.Event()
    try:
        futures = [pool.submit(release.wait, 5) for _ in range(4)]
        assert pool.pending == 4
        with pytest.raises(PoolBusy, match=r'^busy: 4 requests are already running or waiting for the bus '
                                           r'\(at most 4\); nothing was sent'):
            pool.submit(release.wait, 5)
        release.set()
        assert all(f.result(timeout=5) for f in futures)
        wait_for(lambda: pool.pending == 0, 5, 'the pool drained')
        assert pool.submit(lambda: 7).result(timeout=5) == 7
    finally:
        release.set()
        pool.shutdown(wait=True)


def call_batch(ros: RosHarness, client: Any, requests: list[Any]) -> list[Any]:
    futures = [client.call_async(r) for r in requests]
    return wait_for(lambda: [f.result() for f in futures] if all(f.done() for f in futures) else None, 20,
                    f'{len(requests)} answers from {client.srv_name}')


@pytest.mark.slow
def test_a_long_run_of_requests_and_emcys_leaves_nothing_behind(ros: RosHarness) -> None:
    node = start_bridge(ros, demo_data(), node_name='bounds_bridge')
    try:
        node.master.wait_until_operational(15.0)
        client = ros.node('bounds_client')
        read = client.create_client(SdoRead, '/bounds_bridge/sdo_read')
        write = client.create_client(SdoWrite, '/bounds_bridge/sdo_write')
        params = client.create_client(SetParameters, '/bounds_bridge/set_parameters')
        for service in (read, write, params):
            assert service.wait_for_service(timeout_sec=10)
        reads = [SdoRead.Request(node_id=2 + i % 3, index=0x6064, subindex=0) for i in range(8)]
        refused = [SdoWrite.Request(node_id=2, index=0x1017, subindex=0,
                                    value=SdoValue(data_type=SdoValue.UNSIGNED16, uint_value=i)) for i in range(8)]

        def rounds(count: int) -> None:
            for i in range(count):
                assert all(r.success for r in call_batch(ros, read, reads))
                assert all('refused by access.sdo_write' in r.message for r in call_batch(ros, write, refused))
                rate = Parameter('publish_rate', value=float(50 + i % 2 * 50)).to_parameter_msg()
                assert call_batch(ros, params, [SetParameters.Request(parameters=[rate])])[0].results[0].successful
        rounds(5)  # warm-up: pools, clients and caches reach their working size
        process, bus_process = psutil.Process(), psutil.Process(node.master.pid)
        threads, rss = {t.name for t in threading.enumerate()}, process.memory_info().rss
        bus_rss = bus_process.memory_info().rss  # the master's histories live in the bus process
        started = time.monotonic()
        rounds(120)  # 1920 service calls and 120 parameter sets
        with sniffing(node) as bus:  # a participant of the node's local bus
            for i in range(300):  # EMCY "error reset" frames from node 2, each told apart by its last byte
                bus.send(can.Message(arbitration_id=0x82, data=bytes([0, 0, 0, 0, 0, 0, 0, i % 256]),
                                     is_extended_id=False))
                if i % 50 == 49:
                    time.sleep(0.02)
        history = wait_for(lambda: (h := node_snapshot(node, 'base_drive').emcy) and
                           h[-1].manufacturer[-1] == 299 % 256 and h, 10, 'the last EMCY')
        assert len(history) == EMCY_HISTORY
        assert len(node.master.events) <= EVENT_HISTORY
        wait_for(lambda: node.bridge.service_handlers.pool.pending == 0, 5, 'no request left in the pool')
        # nothing new but the pools' workers (started on demand, at most SERVICE_WORKERS of each)
        workers = {f'{pool}_{i}' for pool in ('drive_bridge-srv', 'drive_bridge-axis') for i in range(SERVICE_WORKERS)}
        assert {t.name for t in threading.enumerate()} - threads <= workers
        growth = (process.memory_info().rss - rss) / 2 ** 20
        print(f'RSS growth over the long run: {growth:.2f} MB')
        assert growth < 20, f'RSS grew {growth:.1f} MB over {time.monotonic() - started:.1f} s'
        bus_growth = (bus_process.memory_info().rss - bus_rss) / 2 ** 20
        print(f'bus process RSS growth over the long run: {bus_growth:.2f} MB')
        assert bus_growth < 20, f'the bus process\'s RSS grew {bus_growth:.1f} MB'
        assert node.bridge.service_handlers.pool.limit == MAX_PENDING_REQUESTS
    finally:
        stop_bridge(node)
