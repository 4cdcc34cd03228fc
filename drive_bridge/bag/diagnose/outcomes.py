"""Did the machine recover? Each error finding gets an outcome from what came after it:
heartbeat back, NMT operational again, the axis enabled again, an error-reset EMCY, or
unresolved at the end of the recording."""
from __future__ import annotations

from dataclasses import replace

from drive_bridge.bag.diagnose.cia402 import Cia402Axes
from drive_bridge.bag.diagnose.emcy import EmcyTimeline
from drive_bridge.bag.diagnose.model import Finding, Severity
from drive_bridge.bag.diagnose.nmt import NmtTimeline
from drive_bridge.cia402.statemachine import State


def _after(times: list[float], t: float) -> float | None:
    return next((x for x in times if x > t), None)


class Outcomes:
    """Relative times throughout (findings, timelines)."""

    def __init__(self, nmt: NmtTimeline, emcy: EmcyTimeline, cia402: Cia402Axes) -> None:
        self.operational: dict[int, list[float]] = {}
        for event in nmt.events:
            if event.kind == 'state' and event.node is not None and event.text.endswith(' operational'):
                self.operational.setdefault(event.node, []).append(event.time)
        self.resets: dict[int, list[float]] = {}
        for record in emcy.records:
            if record.event.is_reset:
                self.resets.setdefault(record.node, []).append(record.time)
        self.enabled: dict[int, list[float]] = {}
        self.drives = {axis.node for axis in cia402.axes.values()}  # nodes with CiA 402 axes: enabled again?
        self.left_fault: dict[int, list[float]] = {}
        for axis in cia402.axes.values():
            for t, old, new in axis.transitions:
                if new is State.OPERATION_ENABLED:
                    self.enabled.setdefault(axis.node, []).append(t)
                if old is State.FAULT:
                    self.left_fault.setdefault(axis.node, []).append(t)

    def annotate(self, finding: Finding) -> Finding:
        if finding.severity is not Severity.ERROR or finding.node is None:
            return finding
        node, t = finding.node, finding.time
        outcome = ''
        if finding.kind == 'heartbeat-stopped':
            outcome = 'unresolved at the end of the recording'
        elif finding.kind in ('unexpected-restart', 'heartbeat-gap') and 'boot-up' in finding.what + finding.kind:
            back = _after(self.operational.get(node, []), t)
            outcome = (f'recovered: operational again at t={back:.3f} s' if back is not None
                       else 'unresolved: not operational again in the recording')
        elif finding.kind == 'heartbeat-gap':
            outcome = 'recovered: heartbeat back'
        elif finding.kind in ('emcy', 'cia402-fault'):
            cleared = [x for x in (_after(self.resets.get(node, []), t), _after(self.left_fault.get(node, []), t))
                       if x is not None]
            enabled = _after(self.enabled.get(node, []), t)
            if enabled is not None:
                outcome = f'recovered: operation enabled again at t={enabled:.3f} s'
            elif cleared:
                outcome = f'fault cleared at t={min(cleared):.3f} s' + (
                    ', not enabled again in the recording' if node in self.drives else '')
            else:
                outcome = 'unresolved at the end of the recording'
        return replace(finding, outcome=outcome) if outcome else finding
