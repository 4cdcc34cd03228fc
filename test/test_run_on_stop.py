"""The run-on stop's bookkeeping (``master.run_on.RunOnStop``, core API): a drive that keeps its
last references without a master is stopped while its liveness is lost, until it is at rest; a
pause of its frames (gone) does not end that for good: frames that arrive again resume the stop.
The run through ROS against the simulated OPEN drive is test_motion_safety_ros.py's test 6."""
from __future__ import annotations

import time
from types import SimpleNamespace
from typing import Any

from drive_bridge.master.node import BootState
from drive_bridge.master.run_on import FRAMES_FRESH, RunOnStop


def lost_node(**family: Any) -> Any:
    return SimpleNamespace(node_id=5, name='spindle', boot_state=BootState.LOST,
                           family=SimpleNamespace(boot=SimpleNamespace(runs_on_without_master=True), **family),
                           process=SimpleNamespace(input_stamps={0x185: time.time()}))


def test_a_pause_of_the_frames_does_not_end_the_stop_while_the_drive_is_still_lost() -> None:
    reports: list[str] = []
    stop = RunOnStop(lambda node, level, text: reports.append(f'{level}: {text}'))
    node = lost_node()
    assert stop.due(node) and stop.due(node)  # stop sent every cycle
    assert len(reports) == 1 and 'keeps its last references without a master' in reports[0]

    node.process.input_stamps[0x185] = time.time() - 2 * FRAMES_FRESH  # its frames pause
    assert not stop.due(node) and not stop.due(node)
    assert len(reports) == 2 and 'its frames stopped (gone)' in reports[1]

    node.process.input_stamps[0x185] = time.time()  # back, still lost: it may still be running
    assert stop.due(node)
    assert len(reports) == 3 and 'arrive again' in reports[2] and 'sending its stop again' in reports[2]

    stop.at_rest(node)  # at rest: the end of this loss's stop
    assert 'at rest: stop no longer sent' in reports[3]
    assert not stop.due(node) and len(reports) == 4


def test_a_drive_back_from_its_loss_is_no_longer_stopped_and_a_new_loss_starts_anew() -> None:
    reports: list[str] = []
    stop = RunOnStop(lambda node, level, text: reports.append(text))
    node = lost_node()
    assert stop.due(node)
    stop.at_rest(node)
    node.boot_state = BootState.OPERATIONAL  # configured again: its driver owns its outputs
    assert not stop.due(node)
    node.boot_state = BootState.LOST
    assert stop.due(node)
    assert sum('keeps its last references' in r for r in reports) == 2
