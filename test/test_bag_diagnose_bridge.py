"""The engineer's journey end to end: the bridge records the demo bus (its own recorder, through
ROS) while a trajectory runs and four faults are injected — an EMCY fault, an SDO abort of a
client's request, a heartbeat loss and a drive reboot — and `drive-bridge diagnose` of that bag
names each as a finding at the time it was injected, with the node, the joint and the text.
Times: the findings' times are seconds from the bag's first frame; the bound is generous for a
loaded CI machine."""
from __future__ import annotations

import contextlib
import io
import json
import time
from pathlib import Path
from typing import Any

import pytest
from drive_bridge_interfaces.msg import SdoValue
from drive_bridge_interfaces.srv import SdoWrite
from rclpy.parameter import Parameter
from trajectory_msgs.msg import JointTrajectory

from bridgetools import start_bridge, stop_bridge
from bustools import demo_data
from diagnosetools import check_self_contained
from drive_bridge.bag.source import open_recording
from drive_bridge.cia402.statemachine import State
from drive_bridge.cli.main import main
from nodebench import NS, point
from rostools import RosHarness, wait_for

TOLERANCE = 0.3  # s between the injection (wall clock) and the finding's time


def one(findings: list[dict[str, Any]], kind: str, node: int, text: str = '') -> dict[str, Any]:
    hits = [f for f in findings if f['kind'] == kind and f['node'] == node and text in f['what']]
    assert len(hits) == 1, (kind, node, text, [(f['kind'], f['time'], f['what'], f['cause'], f['outcome'])
                                               for f in findings if f['node'] == node])
    return hits[0]


@pytest.mark.slow
def test_a_bag_the_bridge_recorded_names_each_injected_fault(ros: RosHarness, tmp_path: Path) -> None:
    node = start_bridge(ros, demo_data(), [  # node.simulation: the drives in this process, on the node's bus
        Parameter('auto_enable', value=True),
        Parameter('record.path', value=str(tmp_path / 'bags')), Parameter('record.start', value=True)])
    injected: dict[str, float] = {}
    try:
        node.master.wait_until_operational(10.0)
        wait_for(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10, 'enabled')
        client = ros.node('engineer')
        trajectories = client.create_publisher(JointTrajectory, f'{NS}/joint_trajectory', 10)
        wait_for(lambda: trajectories.get_subscription_count() > 0, 5, 'the bridge subscribed')
        start = node.master.axes['elbow_joint'].snapshot().position
        trajectories.publish(JointTrajectory(joint_names=['elbow_joint'], points=[point(1.5, [start - 0.3])]))
        time.sleep(0.3)
        injected['emcy'] = time.time()
        node.simulation.drive(2).inject_fault(0x2310)
        wait_for(lambda: node.master.axes['base_joint'].snapshot().fault, 3, 'the fault seen')
        time.sleep(0.2)
        injected['sdo-abort'] = time.time()
        refused = ros.call(client.create_client(SdoWrite, f'{NS}/sdo_write'), SdoWrite.Request(
            node_id=3, index=0x6060, subindex=0, value=SdoValue(data_type=SdoValue.INTEGER8, int_value=99)))
        assert not refused.success and refused.abort_code, refused  # a mode the drive does not have
        time.sleep(0.2)
        lift = node.simulation.drive(4)
        injected['heartbeat-loss'] = time.time()
        lift.stop_heartbeat()
        time.sleep(0.7)
        lift.start_heartbeat()
        time.sleep(0.5)
        injected['reboot'] = time.time()
        node.simulation.drive(3).restart()
        wait_for(lambda: any(e.kind.value == 'unexpected_boot' for e in node.master.events), 5, 'reboot noticed')
        time.sleep(0.5)
    finally:
        stop_bridge(node)
    bag, = (tmp_path / 'bags').iterdir()
    t0 = next(iter(open_recording(bag).frames())).timestamp

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rc = main(['diagnose', str(bag), '-o', str(tmp_path / 'r.html'), '--json', str(tmp_path / 'r.json'),
                   '--no-progress', '--check'])
    assert rc == 1, 'error findings: --check fails'
    check_self_contained((tmp_path / 'r.html').read_text(encoding='utf-8'))
    data = json.loads((tmp_path / 'r.json').read_text())
    assert data['inputs']['config'], 'the config stored in the bag was used'
    findings = data['findings']

    def near(finding: dict[str, Any], fault: str) -> None:
        assert abs(finding['time'] - (injected[fault] - t0)) < TOLERANCE, (fault, finding)

    emcy = one(findings, 'emcy', 2, '0x2310')
    assert emcy['joint'] == 'base_joint' and emcy['severity'] == 'error'
    near(emcy, 'emcy')
    abort = one(findings, 'sdo-abort', 3, '0x6060')
    assert f'0x{refused.abort_code:08X}' in abort['what'] and 'write' in abort['what'] and abort['cause']
    near(abort, 'sdo-abort')
    lost = [f for f in findings if f['kind'] == 'heartbeat-gap' and f['node'] == 4]
    assert len(lost) == 1 and lost[0]['joint'] == 'lift_joint' and 'boot-up' not in lost[0]['what']
    near(lost[0], 'heartbeat-loss')
    rebooted = one(findings, 'unexpected-restart', 3)
    assert rebooted['joint'] == 'shoulder_joint, elbow_joint' and 'rebooted' in rebooted['cause']
    assert rebooted['outcome'].startswith('recovered: operational again')  # the bridge booted it again
    near(rebooted, 'reboot')
    # the bridge's own conduct is no finding: its heartbeat (node 127) and its disabling the faulted axis
    own = [(f['kind'], f['node'], f['time'], f['what'], f['cause']) for f in findings
           if f['kind'] in ('config-node-extra', 'cia402-command')]
    assert not own, own
    assert 'base_joint' in out.getvalue() or 'node 2' in out.getvalue(), out.getvalue()
