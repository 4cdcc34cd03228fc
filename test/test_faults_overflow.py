"""Fault catalogue: the AKD's PVT buffer overflows mid-stream (n704, EMCY 0x8584) because a
second master on the bus -- a commissioning tool or a PLC -- pushes interpolation points into
the same drive while the bridge streams a trajectory (config/akd_pvt_example.yaml).

The bridge itself never overflows the buffer (it pushes only while two places are free), so
the tool's points are what fills it: the bridge must abort the stream, hold the axis with
HALT, keep publishing, and after ~/resume neither replay the points queued before the fault
nor refuse the next trajectory."""
from __future__ import annotations

import struct
import threading
import time

import can
import pytest
from control_msgs.action import FollowJointTrajectory
from drive_bridge_interfaces.srv import AxisCommand
from rclpy.parameter import Parameter
from test_pvt_ros import (
    JOINT,
    NS,
    bridge as bridge,  # noqa: F401  (the fixture: the bridge streaming to a simulated AKD)
    follow,
    position_of,
    recorders,
)

from drive_bridge.cia402.statemachine import State
from rostools import ActionClient, RosHarness, wait_for

NODE = 1
SYNC, TPDO2, RPDO2, RPDO3 = 0x080, 0x280 + NODE, 0x300 + NODE, 0x400 + NODE


class SecondMaster:
    """Another master on the same bus, writing the AKD's PVT point (RPDO2: 0x60C1:1 position
    and :2 time, RPDO3: :3 velocity; the manual's map) right after each SYNC: a hold at the
    drive's actual position (from TPDO2) over ``time_ms``, ``count`` times."""

    def __init__(self, channel: str, count: int, time_ms: int = 200) -> None:
        self.bus = can.Bus(interface='local', channel=channel)  # on the bridge's local bus (bridgetools)
        self.count, self.time_ms, self.sent = count, time_ms, 0
        self.actual: int | None = None
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> SecondMaster:
        self._thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.count = 0
        self._thread.join(timeout=2)
        self.bus.shutdown()

    def _run(self) -> None:
        while self.count:  # reads until closed: a local peer that does not read holds the senders back
            msg = self.bus.recv(0.05)
            if msg is None:
                continue
            if msg.arbitration_id == TPDO2:
                self.actual = struct.unpack_from('<i', msg.data)[0]
            elif msg.arbitration_id == SYNC and self.actual is not None and self.sent < self.count:
                self.bus.send(can.Message(arbitration_id=RPDO2, is_extended_id=False,
                                          data=struct.pack('<ii', self.actual, self.time_ms)))
                self.bus.send(can.Message(arbitration_id=RPDO3, is_extended_id=False, data=struct.pack('<i', 0)))
                self.sent += 1


def test_a_second_master_overflows_the_pvt_buffer_and_the_axis_is_held(ros: RosHarness, bridge) -> None:
    states, emcys, _publisher = recorders(ros)
    watcher = ros.node('overflow_watch')
    client = ActionClient(watcher, FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
    resume = watcher.create_client(AxisCommand, f'{NS}/resume')
    assert client.wait_for_server(timeout_sec=10)
    drive = bridge.simulation.drive(NODE)

    # points 40 ms apart kept 200 ms ahead: a stalled cycle on a loaded machine cannot starve
    # the stream, and the bridge still leaves room (it queues at most 5 of the 9 places)
    assert all(r.successful for r in bridge.set_parameters([Parameter('pvt_segment', value=0.04),
                                                            Parameter('pvt_lookahead', value=0.2)]))
    here = position_of(states[-1])
    result_future = follow(client, here + 2.0, 2.0)
    time.sleep(0.5)  # the stream runs, the buffer is kept fed (never full)
    assert not [e for e in emcys if e.error_code in (0x8584, 0x8585)]  # fed, never full
    with SecondMaster(bridge.master.config.bus.channel, count=15):
        overflow = wait_for(lambda: next((e for e in emcys if e.error_code == 0x8584), None), 3, 'EMCY 0x8584')
        result = wait_for(lambda: result_future.result() if result_future.done() else None, 5, 'result').result
    assert overflow.node_id == NODE and overflow.joint_name == JOINT
    assert 'overflow' in overflow.text.lower()
    assert result.error_code == FollowJointTrajectory.Result.PATH_TOLERANCE_VIOLATED
    assert '0x8584' in result.error_string and 'overflow' in result.error_string and 'held' in result.error_string

    # held: HALT on the drive, still enabled, standing still; the bridge keeps publishing
    snapshot = bridge.master.axes[JOINT].snapshot()
    assert snapshot.halted and snapshot.state is State.OPERATION_ENABLED
    wait_for(lambda: drive.axis(0).controlword & 0x110 == 0x100, 2, 'HALT, interpolation off (bit 4) on the drive')
    wait_for(lambda: abs(dict(zip(states[-1].name, states[-1].velocity))[JOINT]) < 1e-3, 3, 'standstill')
    held, count = position_of(states[-1]), len(states)
    time.sleep(0.4)
    assert len(states) > count + 5  # /joint_states keep coming (about 100 in 0.4 s)
    assert position_of(states[-1]) == pytest.approx(held, abs=1e-4)  # holding, not drifting
    assert here + 0.05 < held < here + 2.0

    # released: the points queued before the fault are not replayed, the next goal runs
    axis = bridge.master.axes[JOINT]
    assert drive.value(0x60C4, 2) < 9  # 0x60C4:2 (TPDO1 carries it): points still queued in the drive
    before_resume = len(emcys)
    response = ros.call(resume, AxisCommand.Request(joints=[JOINT]))
    assert response.success, response.message
    wait_for(lambda: drive.value(0x60C4, 2) == 9, 2, 'the drive buffer cleared')
    time.sleep(0.5)
    assert position_of(states[-1]) == pytest.approx(held, abs=1e-3), 'the drive replayed stale points'
    second = follow(client, held - 0.5, 1.0)
    result = wait_for(lambda: second.result() if second.done() else None, 5, 'second result')
    assert result.result.error_code == FollowJointTrajectory.Result.SUCCESSFUL, result.result.error_string
    wait_for(lambda: abs(position_of(states[-1]) - (held - 0.5)) < 1e-3, 3, 'the second goal')
    assert not [e for e in emcys[before_resume:] if e.error_code in (0x8584, 0x8585)]
    assert axis.snapshot().state is State.OPERATION_ENABLED
