"""Fault catalogue through ROS: an EMCY fault in the middle of a FollowJointTrajectory goal,
an SDO timeout in the middle of a service call, a stale node on /diagnostics. Each is
reported with node, joint and cause, and the bridge keeps serving the other joints."""
from __future__ import annotations

import time

import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from drive_bridge_interfaces.msg import AxisStates
from drive_bridge_interfaces.srv import SdoRead
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from bridgetools import fresh_snapshot, node_snapshot, sniffing
from bustools import demo_data
from drive_bridge.cia402.statemachine import State
from faulttools import demo_bridge
from rostools import ActionClient, RosHarness, wait_for
from timingtools import BUSY_SLACK

NS = '/drive_bridge'
Result = FollowJointTrajectory.Result


@pytest.fixture
def bridge(ros: RosHarness):
    with demo_bridge(ros) as node:
        yield node


def goal(ros: RosHarness, client: ActionClient, joints: list[str], targets: list[float], seconds: float):
    t = Duration(sec=int(seconds), nanosec=round((seconds % 1) * 1e9))
    trajectory = JointTrajectory(joint_names=joints, points=[JointTrajectoryPoint(positions=targets,
                                                                                  time_from_start=t)])
    sent = client.send_goal_async(FollowJointTrajectory.Goal(trajectory=trajectory))
    handle = wait_for(lambda: sent.result() if sent.done() else None, 10, 'goal response')
    return handle.get_result_async()


def result_of(future, timeout: float = 10.0):
    return wait_for(lambda: future.result() if future.done() else None, timeout, 'goal result').result


def test_an_emcy_fault_mid_goal_aborts_it_with_the_cause_and_the_other_joints_go_on(ros: RosHarness,
                                                                                  bridge) -> None:
    client = ActionClient(ros.node('fault_goal'), FollowJointTrajectory, f'{NS}/follow_joint_trajectory')
    assert client.wait_for_server(timeout_sec=10)
    axes = bridge.master.axes
    base, lift = axes['base_joint'].snapshot().position, axes['lift_joint'].snapshot().position
    running = goal(ros, client, ['base_joint', 'lift_joint'], [base + 0.5, lift + 0.05], 2.0)
    time.sleep(0.5)
    bridge.simulation.drive(2).inject_fault(0x2310)
    result = result_of(running)
    assert result.error_code == Result.PATH_TOLERANCE_VIOLATED
    assert result.error_string.startswith('aborted: joint base_joint left operation enabled')
    assert '0x2310' in result.error_string and 'continuous over-current' in result.error_string
    wait_for(lambda: axes['base_joint'].snapshot().state is State.FAULT, 3, 'base_joint in FAULT')
    # the other joint is held, then served by a new goal
    lift_now = axes['lift_joint'].snapshot().position
    again = result_of(goal(ros, client, ['lift_joint'], [lift_now + 0.02], 0.5))
    assert again.error_code == Result.SUCCESSFUL, again.error_string


SLOW_SDO_TIMEOUT = 1.5  # s: node 3's SDO timeout in the next test, longer than a busy machine's stalls


@pytest.fixture
def slow_sdo_bridge(ros: RosHarness):
    data = demo_data()
    data['nodes']['arm_drive'].update(sdo_timeout_ms=round(SLOW_SDO_TIMEOUT * 1000), sdo_retries=0)
    with demo_bridge(ros, data) as node:
        yield node


def test_an_sdo_timeout_mid_call_names_node_and_object_and_nothing_else_waits(ros: RosHarness,
                                                                            slow_sdo_bridge) -> None:
    bridge = slow_sdo_bridge
    states: list[float] = []
    ros.node('sdo_states').create_subscription(JointState, '/joint_states',
                                               lambda _m: states.append(time.monotonic()), 100)
    wait_for(lambda: states, 5, 'joint states')
    client = ros.node('sdo_slow').create_client(SdoRead, f'{NS}/sdo_read')
    # the answer comes after the timeout and after the one retry's (canopen retries once)
    bridge.simulation.drive(3).set_sdo_delay(2 * SLOW_SDO_TIMEOUT + 0.5)
    since = time.monotonic()
    response = ros.call(client, SdoRead.Request(node_id=3, index=0x1018, subindex=2), timeout=15)
    assert not response.success
    assert response.message.startswith('node 3 object 0x1018:02: no valid SDO response')
    gaps = [b - a for a, b in zip([since, *states], states) if a >= since]
    # /joint_states never paused for the call (a call that blocked would pause them for the
    # 1.5 s timeout; a busy machine pauses them by itself for up to BUSY_SLACK)
    assert gaps and max(gaps) < BUSY_SLACK < SLOW_SDO_TIMEOUT, max(gaps)
    assert all(a.snapshot().state is State.OPERATION_ENABLED for a in bridge.master.axes.values())
    assert node_snapshot(bridge, 'arm_drive', fresh=True).available  # a slow SDO is not a lost node
    other = ros.call(client, SdoRead.Request(node_id=2, index=0x1018, subindex=2), timeout=15)
    assert other.success and other.value.uint_value == 0x402
    bridge.simulation.drive(3).set_sdo_delay(0.0)
    time.sleep(SLOW_SDO_TIMEOUT + 1.0)  # the late answers of the timed-out request arrive and are dropped
    healed = ros.call(client, SdoRead.Request(node_id=3, index=0x1018, subindex=2), timeout=15)
    assert healed.success and healed.value.uint_value == 0x402


def test_a_stale_node_shows_on_diagnostics_and_axis_states(ros: RosHarness, bridge) -> None:
    diagnostics: list[DiagnosticArray] = []
    axis_states: list[AxisStates] = []
    ros.node('stale_diag').create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 10)
    ros.node('stale_axes').create_subscription(AxisStates, f'{NS}/axis_states', axis_states.append, 10)
    bridge.simulation.drive(4).stop_tpdos()

    def node_status():
        for array in reversed(diagnostics):
            for status in array.status:
                if status.name.endswith('node lift_drive') and 'stale' in status.message:
                    return status
        return None
    status = wait_for(node_status, 5, 'lift_drive stale on /diagnostics')
    assert status.level == DiagnosticStatus.ERROR
    assert status.message.startswith('TPDO1 0x184 stale: none for ')

    def lift_state():
        for msg in reversed(axis_states):
            for axis in msg.axes:
                if axis.joint_name == 'lift_joint' and not axis.available:
                    return axis
        return None
    state = wait_for(lift_state, 5, 'lift_joint unavailable on ~/axis_states')
    assert 'TPDO1 0x184 stale' in state.message and state.halted


def test_a_babbling_node_is_rate_limited_on_emcy_and_the_log(ros: RosHarness, bridge) -> None:
    import can
    from drive_bridge_interfaces.msg import Emcy
    from rcl_interfaces.msg import Log

    from drive_bridge.master.flood import EMCY_BURST, EMCY_RATE
    emcys: list[Emcy] = []
    logs: list[Log] = []
    ros.node('flood_emcy').create_subscription(Emcy, f'{NS}/emcy', emcys.append, 1000)
    ros.node('flood_log').create_subscription(Log, '/rosout', logs.append, 1000)
    time.sleep(0.3)  # discovery
    with sniffing(bridge) as rogue:  # a participant of the node's local bus
        start = time.monotonic()
        for _ in range(2000):  # as fast as this process can: above a 1 Mbit/s bus's rate
            rogue.send(can.Message(arbitration_id=0x082, data=b'\x00\x10\x01\x00\x00\x00\x00\x00',
                                   is_extended_id=False))
        took = time.monotonic() - start
    wait_for(lambda: any('EMCY flood' in m.msg for m in logs), 3, 'the flood logged')
    time.sleep(0.5)
    # at most the rate over the time since the first (the receive thread may lag the sender)
    bound = EMCY_BURST + EMCY_RATE * (time.monotonic() - start) + 5
    assert len(emcys) <= bound, (len(emcys), took)
    assert len([m for m in logs if '0x1000' in m.msg]) <= bound
    node = next(n for n in fresh_snapshot(bridge).nodes if n.node_id == 2)
    assert node.emcy_suppressed >= 2000 - bound
    assert all(a.snapshot().state is State.OPERATION_ENABLED for a in bridge.master.axes.values())
