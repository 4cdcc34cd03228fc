"""What every analyser shares: findings, and the context the inputs give (names, joints, families)."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # not imported to diagnose: canopen and the families cost a fast run its start-up
    from canopen.objectdictionary import ObjectDictionary

    from drive_bridge.families.interface import DriveFamily


class Severity(str, Enum):
    """How bad a finding is; ``--check`` fails on ERROR."""

    INFO = 'info'
    WARNING = 'warning'
    ERROR = 'error'


SEVERITY_ORDER = {Severity.ERROR: 0, Severity.WARNING: 1, Severity.INFO: 2}


@dataclass(frozen=True)
class Finding:
    """One thing a person diagnosing the machine should know: what was seen and why, probably."""

    severity: Severity
    time: float  # s since the recording's first frame
    node: int | None
    what: str
    cause: str = ''
    joint: str | None = None
    kind: str = ''  # a short stable tag for tools: 'heartbeat-gap', 'sdo-abort', 'emcy', ...
    outcome: str = ''  # errors: 'recovered: ...' / 'unresolved ...' (from what came after)
    short: str = ''  # the verdict line's words for it ('node 2 booted 1.2 s late'); default: what
    seq: int = 0  # Context.events when it was found: its order where time stamps are missing

    @property
    def headline(self) -> str:
        return self.short or (f'node {self.node}: ' if self.node is not None else '') + self.what

    def to_json(self) -> dict[str, Any]:
        return {'severity': self.severity.value, 'time': round(self.time, 6), 'node': self.node,
                'joint': self.joint, 'kind': self.kind, 'what': self.what, 'cause': self.cause,
                'outcome': self.outcome, 'short': self.headline}

    def where(self) -> str:
        where = f'node {self.node}' if self.node is not None else 'bus'
        return where + (f' ({self.joint})' if self.joint else '')

    def __str__(self) -> str:
        cause = f': {self.cause}' if self.cause else ''
        outcome = f' [{self.outcome}]' if self.outcome else ''
        return f'{self.severity.value.upper():7} t={self.time:9.3f} s  {self.where()}: {self.what}{cause}{outcome}'


@dataclass
class NodeInfo:
    """What the inputs (config or EDS) say about a node."""

    node_id: int
    name: str = ''
    family: DriveFamily | None = None
    od: ObjectDictionary | None = None
    joints: dict[int, str] = field(default_factory=dict)  # axis slot -> joint
    position_factor: dict[int, float] = field(default_factory=dict)  # axis slot -> SI per count
    following_limit: dict[int, float] = field(default_factory=dict)  # axis slot -> SI (position loop)
    heartbeat_ms: int = 0  # the configured producer time
    guard_time_ms: int = 0


@dataclass
class Context:
    """Inputs plus the time origin; analysers add findings here."""

    nodes: dict[int, NodeInfo] = field(default_factory=dict)
    bitrate: int | None = None
    sync_period: float | None = None
    t0: float = 0.0
    findings: list[Finding] = field(default_factory=list)
    timing: bool = True  # False: no time stamps, or synthetic ones: timing findings are not judged
    master: int | None = None  # the master's node id (config, else as the traffic shows), None: not known
    events: int = 0  # NMT, SDO and error-control events so far: their order where time stamps are missing
    syncs: int = 0  # SYNC frames so far
    states: dict[int, int] = field(default_factory=dict)  # node -> NMT state as its error control / NMT says now

    def node(self, node_id: int) -> NodeInfo:
        info = self.nodes.get(node_id)
        if info is None:
            info = self.nodes[node_id] = NodeInfo(node_id)
        return info

    def label(self, node_id: int) -> str:
        info = self.nodes.get(node_id)
        return f'node {node_id}' + (f' ({info.name})' if info and info.name else '')

    def joint(self, node_id: int | None, slot: int | None = 0) -> str | None:
        """The joint of an axis slot; ``slot`` None (the node as a whole): all its joints."""
        info = self.nodes.get(node_id) if node_id is not None else None
        if not info:
            return None
        if slot is None:
            return ', '.join(info.joints[k] for k in sorted(info.joints)) or None
        return info.joints.get(slot)

    def add(self, severity: Severity, t: float, node: int | None, what: str, cause: str = '',
            kind: str = '', slot: int | None = None, short: str = '') -> Finding:
        finding = Finding(severity, t - self.t0, node, what, cause, self.joint(node, slot), kind, short=short,
                          seq=self.events)
        self.findings.append(finding)
        return finding
