"""The bus process's full outbox, seen through ROS: the reports it drops are counted on the bus
status of ``/diagnostics`` (``reports_dropped_at_boundary``), WARN once not 0.

Filling a 10,000-record outbox takes a node that stops reading for long; here the bus process
starts with a smaller bound instead: a ``sitecustomize`` module in this test's directory (on the
children's PYTHONPATH) sets ``busproc.outbox.MAX_RECORDS`` to 0 when DRIVE_BRIDGE_TEST_OUTBOX_RECORDS
says so, so every report that is not an answer (the boot's events among them) is dropped. No hook
in the bridge.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.parameter import Parameter

from bridgetools import bridge_with_sim
from bustools import demo_data
from rostools import RosHarness, wait_for

SITECUSTOMIZE = """
import os
if os.environ.get('DRIVE_BRIDGE_TEST_OUTBOX_RECORDS'):
    from drive_bridge.busproc import outbox
    outbox.MAX_RECORDS = int(os.environ['DRIVE_BRIDGE_TEST_OUTBOX_RECORDS'])
"""


def test_reports_the_full_outbox_dropped_warn_on_diagnostics(ros: RosHarness, tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / 'sitecustomize.py').write_text(SITECUSTOMIZE)
    monkeypatch.setenv('PYTHONPATH', os.pathsep.join(filter(None, [str(tmp_path), os.environ.get('PYTHONPATH')])))
    monkeypatch.setenv('DRIVE_BRIDGE_TEST_OUTBOX_RECORDS', '0')
    diagnostics: list[DiagnosticArray] = []
    ros.node('outbox_diag').create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 50)
    with bridge_with_sim(ros, demo_data(), [Parameter('diagnostics_period', value=0.2)]) as node:
        node.master.wait_until_operational(15)  # an answer: answers always go

        def warned() -> DiagnosticStatus | None:
            return next((s for array in reversed(diagnostics) for s in array.status
                         if s.name.startswith('drive_bridge: bus') and s.level == DiagnosticStatus.WARN
                         and 'reports of the bus process dropped' in s.message), None)
        status = wait_for(warned, 15, 'the bus status WARN for the dropped reports')
        values = {v.key: v.value for v in status.values}
        assert int(values['reports_dropped_at_boundary']) > 0
        assert status.message.startswith(f'{values["reports_dropped_at_boundary"]} reports of the bus process dropped')
        assert not node.master.events  # the boot's events never reached the node
