"""The stop lane: ``~/quick_stop`` answers while other clients occupy everything else.

Ten ``~/set_mode`` calls with a manufacturer mode the drive never confirms and the longest
timeout hold the node's service workers; twenty clients call ``~/sdo_read`` back to back. A
quick stop still reaches the drive and is answered, because it never enters that pool and
crosses to the bus process on a lane of its own (the measured figure, goal 50 ms, is in
``bench boundary``; the bound here is the issue's 1 s)."""
from __future__ import annotations

import threading
import time

from drive_bridge_interfaces.srv import AxisCommand, SdoRead, SetMode
from rclpy.parameter import Parameter

from bridgetools import bridge_with_sim
from bustools import demo_data
from drive_bridge.cia402.statemachine import State
from rostools import RosHarness, wait_for

NS = '/drive_bridge'


def test_quick_stop_answers_while_long_calls_and_a_flood_hold_every_other_worker(ros: RosHarness) -> None:
    with bridge_with_sim(ros, demo_data(), [Parameter('auto_enable', value=True)]) as node:
        node.master.wait_until_operational(10)
        wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10, 'enabled')
        clients = ros.node('stoplane_clients')
        set_mode = clients.create_client(SetMode, f'{NS}/set_mode')
        assert set_mode.wait_for_service(timeout_sec=10)
        hanging = [set_mode.call_async(SetMode.Request(joints=['shoulder_joint'], mode='-100', timeout=30.0))
                   for _ in range(10)]
        stop = threading.Event()

        def hammer(k: int) -> None:
            client = ros.node(f'stoplane_sdo_{k}').create_client(SdoRead, f'{NS}/sdo_read')
            client.wait_for_service(timeout_sec=10)
            while not stop.is_set():
                future = client.call_async(SdoRead.Request(node_id=2, index=0x6041, subindex=0))
                while not future.done() and not stop.is_set():
                    time.sleep(0.001)
        hammers = [threading.Thread(target=hammer, args=(k,), daemon=True) for k in range(20)]
        for thread in hammers:
            thread.start()
        try:
            time.sleep(1.0)  # the long calls and the flood are in
            assert not any(f.done() for f in hanging[:8])  # the workers are taken
            quick_stop = clients.create_client(AxisCommand, f'{NS}/quick_stop')
            assert quick_stop.wait_for_service(timeout_sec=10)
            sent = time.monotonic()
            response = ros.call(quick_stop, AxisCommand.Request(joints=['base_joint', 'lift_joint']), timeout=10)
            answered = time.monotonic() - sent
            assert response.success, response.message
            assert answered < 1.0, f'quick stop answered after {answered:.3f} s'
            for node_id in (2, 4):
                assert node.simulation.drive(node_id).axis(0).state in (State.QUICK_STOP_ACTIVE,
                                                                       State.SWITCH_ON_DISABLED)
            halt = clients.create_client(AxisCommand, f'{NS}/halt')
            assert ros.call(halt, AxisCommand.Request(joints=['elbow_joint']), timeout=2).success
            wait_for(lambda: node.simulation.drive(3).axis(1).controlword & 0x100, 2, 'HALT on the drive')
        finally:
            stop.set()
            for thread in hammers:
                thread.join(5)
