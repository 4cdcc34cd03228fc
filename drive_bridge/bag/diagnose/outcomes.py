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

Mark = tuple[float, int]  # (relative time, event sequence number): order also without time stamps


def _after(times: list[Mark], t: Mark) -> float | None:
    return next((x[0] for x in times if x > t), None)


class Outcomes:
    """Relative times throughout (findings, timelines), with the events' sequence numbers."""

    def __init__(self, nmt: NmtTimeline, emcy: EmcyTimeline, cia402: Cia402Axes, timing: bool = True) -> None:
        self.at = (lambda t: f' at t={t:.3f} s') if timing else (lambda t: ' later')  # no time stamps: the order
        self.operational: dict[int, list[Mark]] = {}
        for event in nmt.events:
            if event.kind == 'state' and event.node is not None and event.text.endswith(' operational'):
                self.operational.setdefault(event.node, []).append((event.time, event.seq))
        self.resets: dict[int, list[Mark]] = {}
        for record in emcy.records:
            if record.event.is_reset:
                self.resets.setdefault(record.node, []).append((record.time, record.seq))
        self.enabled: dict[int, list[Mark]] = {}
        self.drives = {axis.node for axis in cia402.axes.values()}  # nodes with CiA 402 axes: enabled again?
        self.left_fault: dict[int, list[Mark]] = {}
        for axis in cia402.axes.values():
            for (t, old, new), seq in zip(axis.transitions, axis.seqs):
                if new is State.OPERATION_ENABLED:
                    self.enabled.setdefault(axis.node, []).append((t, seq))
                if old is State.FAULT:
                    self.left_fault.setdefault(axis.node, []).append((t, seq))

    def annotate(self, finding: Finding) -> Finding:
        if finding.severity is not Severity.ERROR or finding.node is None:
            return finding
        node, t = finding.node, (finding.time, finding.seq)
        outcome = ''
        if finding.kind == 'heartbeat-stopped':
            outcome = 'unresolved at the end of the recording'
        elif finding.kind in ('unexpected-restart', 'heartbeat-gap') and 'boot-up' in finding.what + finding.kind:
            back = _after(self.operational.get(node, []), t)
            outcome = (f'recovered: operational again{self.at(back)}' if back is not None
                       else 'unresolved: not operational again in the recording')
        elif finding.kind == 'heartbeat-gap':
            outcome = 'recovered: heartbeat back'
        elif finding.kind in ('emcy', 'cia402-fault'):
            cleared = [x for x in (_after(self.resets.get(node, []), t), _after(self.left_fault.get(node, []), t))
                       if x is not None]
            enabled = _after(self.enabled.get(node, []), t)
            if enabled is not None:
                outcome = f'recovered: operation enabled again{self.at(enabled)}'
            elif cleared:
                outcome = f'fault cleared{self.at(min(cleared))}' + (
                    ', not enabled again in the recording' if node in self.drives else '')
            else:
                outcome = 'unresolved at the end of the recording'
        return replace(finding, outcome=outcome) if outcome else finding
