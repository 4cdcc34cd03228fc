"""The one pass: every frame is dispatched on its COB-ID through a 2048-entry table to the
analyser of its CANopen service; decoded object values (SDO, PDO) are routed to the axis
analysers. Per-frame work is a table lookup, the bus-load bin and the service's own handler."""
from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from itertools import chain, islice
from typing import TYPE_CHECKING, Any

from drive_bridge.bag.candump import ERR, EXT, RTR, RawFrame
from drive_bridge.bag.diagnose.boot import BootAnalysis
from drive_bridge.bag.diagnose.buserrors import BusErrors
from drive_bridge.bag.diagnose.busload import BIN_S, EXT_NOMINAL, EXT_STUFF, NOMINAL, STUFF, BusLoad
from drive_bridge.bag.diagnose.cia402 import Cia402Axes
from drive_bridge.bag.diagnose.emcy import EmcyTimeline
from drive_bridge.bag.diagnose.errors import DiagnoseError
from drive_bridge.bag.diagnose.following import FollowingError
from drive_bridge.bag.diagnose.identity import Identities
from drive_bridge.bag.diagnose.inputs import DiagnoseInputs, context_for
from drive_bridge.bag.diagnose.liveness import Liveness
from drive_bridge.bag.diagnose.model import SEVERITY_ORDER, Context, Finding, Severity
from drive_bridge.bag.diagnose.names import is_signed
from drive_bridge.bag.diagnose.nmt import NmtTimeline
from drive_bridge.bag.diagnose.outcomes import Outcomes
from drive_bridge.bag.diagnose.pdo import Pdos
from drive_bridge.bag.diagnose.sdo import SdoLog, SdoTransaction
from drive_bridge.bag.diagnose.sync import SyncStats
from drive_bridge.bag.diagnose.timebase import TIMEBASE_FRAMES, timebase

if TYPE_CHECKING:
    from drive_bridge.bag.source import Recording

Handler = Callable[[float, int, Any], None]
# COB-IDs a node sends itself (EMCY, TPDO1-4, SDO response, error control): "seen" means these
FROM_NODE = (0x080, 0x180, 0x280, 0x380, 0x480, 0x580, 0x700)
TO_NODE = (0x200, 0x300, 0x400, 0x500, 0x600)


@dataclass
class Diagnosis:
    """Everything one pass found; the report modules render it."""

    path: str
    format: str
    ctx: Context
    inputs: DiagnoseInputs
    frames: int = 0
    t0: float = 0.0
    duration: float = 0.0
    error_frames: int = 0
    extended_frames: int = 0
    remote_frames: int = 0
    first_error: float = 0.0  # time of the first error frame
    timebase: str = 'recorded'  # 'recorded', 'none' (no time stamps) or 'synthetic (...)'
    counts: list[int] = field(default_factory=lambda: [0] * 2048)  # data frames per COB-ID
    remote_counts: list[int] = field(default_factory=lambda: [0] * 2048)  # RTR frames per COB-ID
    nmt: NmtTimeline = field(init=False)
    liveness: Liveness = field(init=False)
    sdo: SdoLog = field(init=False)
    identities: Identities = field(init=False)
    emcy: EmcyTimeline = field(init=False)
    cia402: Cia402Axes = field(init=False)
    following: FollowingError = field(init=False)
    sync: SyncStats = field(init=False)
    busload: BusLoad = field(init=False)
    pdo: Pdos = field(init=False)
    bus_errors: BusErrors = field(init=False)

    @property
    def findings(self) -> list[Finding]:
        return sorted(self.ctx.findings, key=lambda f: (f.time, SEVERITY_ORDER[f.severity]))

    def count(self, severity: Severity) -> int:
        return sum(1 for f in self.ctx.findings if f.severity is severity)

    def nodes_seen(self) -> list[int]:
        return [n for n in range(1, 128) if any(self.counts[base + n] for base in FROM_NODE)]

    def nodes_addressed_only(self) -> list[int]:
        seen = set(self.nodes_seen())
        return [n for n in range(1, 128) if n not in seen and (
            any(self.counts[base + n] for base in TO_NODE) or self.remote_counts[0x700 + n])]

    def frames_from(self, node: int) -> int:
        return sum(self.counts[base + node] for base in FROM_NODE)


class Engine:
    def __init__(self, recording: Recording, inputs: DiagnoseInputs) -> None:
        ctx = context_for(inputs)
        d = self.d = Diagnosis(str(recording.path), recording.format, ctx, inputs)
        d.nmt = NmtTimeline(ctx)
        d.liveness = Liveness(ctx, d.nmt, d.frames_from)
        d.identities = Identities(ctx)
        d.sdo = SdoLog(ctx, self._sdo_done)
        d.emcy = EmcyTimeline(ctx, d.nmt)
        d.bus_errors = BusErrors(ctx)
        d.cia402 = Cia402Axes(ctx, d.emcy)
        d.following = FollowingError(ctx)
        d.sync = SyncStats(ctx)
        d.busload = BusLoad(ctx)
        self.sinks = {0x6040: d.cia402.controlword, 0x6041: d.cia402.statusword,
                      0x6060: d.cia402.mode, 0x6061: d.cia402.mode_display,
                      0x6062: d.following.position_demand, 0x6064: d.following.actual,
                      0x607A: d.following.target_position}
        d.pdo = Pdos(ctx, d.identities, self.sinks, ctx.states)
        self.handlers: list[Handler | None] = [None] * 2048
        h = self.handlers
        h[0] = d.nmt.command
        h[0x80] = self._sync
        for cob in range(0x81, 0x100):
            h[cob] = d.emcy.frame
        for cob in range(0x181, 0x580):
            if cob & 0x7F:
                h[cob] = d.pdo.frame
        for cob in range(0x581, 0x600):
            h[cob] = d.sdo.response
        for cob in range(0x601, 0x680):
            h[cob] = d.sdo.request
        for cob in range(0x701, 0x780):
            h[cob] = d.liveness.frame
        d.pdo.register = self._register_pdo
        if inputs.config is not None:
            for node in inputs.config.nodes:
                for kind, pdos in (('RPDO', node.rpdo), ('TPDO', node.tpdo)):
                    for pdo in pdos:
                        if pdo.enabled:
                            d.pdo.configure(node.node_id, kind, pdo.number, pdo.cob_id,
                                            tuple((e.index, e.subindex, e.bits) for e in pdo.mapping), 'config')

    def _register_pdo(self, cob: int) -> None:
        if 0 < cob < 2048 and cob != 0x80:
            self.handlers[cob] = self.d.pdo.frame

    def _sync(self, t: float, cob: int, data: Any) -> None:
        self.d.sync.times.append(t)
        self.d.pdo.last_sync = t
        self.d.ctx.syncs += 1

    # -- object values ---------------------------------------------------------------------
    def _sdo_done(self, txn: SdoTransaction) -> None:
        d = self.d
        d.identities.sdo(txn)
        d.pdo.sdo(txn)
        value = txn.value
        if value is None:
            return
        index = txn.index
        if index == 0x1017 and txn.write and txn.subindex == 0:
            d.liveness.node(txn.node).producer_ms = value
            return
        if not 0x6000 <= index < 0xA000:  # the values the analysers follow are CiA 402 axis objects'
            return
        info = d.ctx.nodes.get(txn.node)
        bits = 8 * len(txn.data)
        if is_signed(info.od if info else None, index, txn.subindex) and value >> (bits - 1):
            value -= 1 << bits
        if ((index - 0x6000) & 0x7FF) == 0x65:  # following error window
            d.following.window(txn.node, (index - 0x6000) >> 11, value)
        self.object_value(txn.t_response or txn.t_request, txn.node, index, txn.subindex, value)

    def object_value(self, t: float, node: int, index: int, subindex: int, value: int) -> None:
        """A value of a CiA 402 axis object read or written by SDO, to the analyser that follows it."""
        if not 0x6000 <= index < 0xA000 or subindex:
            return
        sink = self.sinks.get(0x6000 + ((index - 0x6000) & 0x7FF))
        if sink is not None:
            sink(t, node, (index - 0x6000) >> 11, value)

    # -- the pass --------------------------------------------------------------------------
    def run(self, frames: Iterable[RawFrame]) -> Diagnosis:
        d = self.d
        frames = iter(frames)
        head = list(islice(frames, TIMEBASE_FRAMES))
        d.timebase = timebase(head)
        d.ctx.timing = d.timebase == 'recorded'
        handlers = self.handlers
        counts = d.counts
        remote_counts = d.remote_counts
        nominal_bins = d.busload.nominal
        stuffed_bins = d.busload.stuffed
        emcy = d.emcy
        inv = 1.0 / BIN_S
        t0: float | None = None
        n = errors = extended = remote = backwards = invalid = 0
        t = last = end = 0.0
        first_back = first_invalid = 0.0
        prev = -1
        liveness = d.liveness
        error_frames = d.bus_errors
        for t, cob, flags, data in chain(head, frames):
            if t0 is None:
                t0 = d.t0 = d.ctx.t0 = last = end = t
            n += 1
            if t < last:  # a trace merged from two sources, or a clock stepped: counted, binned at the start
                if not backwards:
                    first_back = t
                backwards += 1
            elif t > end:
                end = t
            last = t
            size = len(data)
            dlc = size if size <= 8 else 8
            b = int((t - t0) * inv) if t >= t0 else 0
            if b >= len(nominal_bins):
                d.busload.grow(b + 64)
            if flags & 7:
                if flags & ERR:
                    if not errors:
                        d.first_error = t
                    errors += 1
                    error_frames.frame(t, cob, data)
                    continue
                if flags & EXT:
                    extended += 1
                    nominal_bins[b] += EXT_NOMINAL[0 if flags & RTR else dlc]
                    stuffed_bins[b] += EXT_STUFF[0 if flags & RTR else dlc]
                    continue
                if cob <= 0x7FF:
                    remote += 1
                    remote_counts[cob] += 1
                    nominal_bins[b] += NOMINAL[0]
                    stuffed_bins[b] += STUFF[0]
                    if 0x700 < cob < 0x780:
                        liveness.frame(t, cob, b'', True)
                    prev = cob
                    continue
            if cob > 0x7FF:  # not an 11-bit identifier: a broken trace line
                if not invalid:
                    first_invalid = t
                invalid += 1
                continue
            counts[cob] += 1
            nominal_bins[b] += NOMINAL[dlc]
            stuffed_bins[b] += STUFF[dlc]
            handler = handlers[cob]
            if handler is not None:
                if 0x80 < cob < 0x100:
                    emcy.prev_cob = prev if prev >= 0 else None
                handler(t, cob, data)
            prev = cob
        if t0 is None:
            raise DiagnoseError(f'{d.path}: the recording holds no CAN frames')
        d.frames, d.error_frames, d.extended_frames, d.remote_frames = n, errors, extended, remote
        d.duration = end - t0
        del nominal_bins[int(d.duration * inv) + 1:]
        del stuffed_bins[int(d.duration * inv) + 1:]
        if backwards and d.ctx.timing:
            d.ctx.add(Severity.WARNING, max(first_back, t0), None, f'clock went back {backwards} times',
                      'frames out of time order (traces merged, or the logger\'s clock stepped): '
                      'their times count from the start of the recording', 'clock-backwards')
        if invalid:
            d.ctx.add(Severity.WARNING, first_invalid, None,
                      f'{invalid} frame(s) with a standard identifier above 0x7FF skipped',
                      'an 11-bit CAN identifier is at most 0x7FF: the trace is damaged or misparsed',
                      'invalid-id')
        self._finish(end)
        return d

    def _finish(self, end: float) -> None:
        d = self.d
        ctx = d.ctx
        d.sdo.finish(end)
        d.liveness.finish(end)
        d.identities.finish()
        d.cia402.finish(end)
        d.following.finish()
        d.sync.finish()
        if ctx.timing:
            d.busload.finish()
        d.pdo.finish(d.sync.nominal)
        if ctx.master is None:
            ctx.master = self._master()
        d.emcy.finish(ctx.master)
        BootAnalysis(ctx, d.nmt, d.sdo).finish(end)
        self._check_config()
        d.bus_errors.finish()
        if not ctx.timing:
            why = ('the log has no time stamps (pasted screen output)' if d.timebase == 'none' else
                   f'its time stamps are synthetic ({d.timebase})')
            ctx.add(Severity.INFO, d.t0, None, f'timing not judged: {why}',
                    'heartbeat and SYNC periods, gaps, PDO rates, SDO latencies and the bus load need the bus\'s '
                    'own time stamps (candump -L, or -t a)', 'timebase')
        outcomes = Outcomes(d.nmt, d.emcy, d.cia402, ctx.timing)
        ctx.findings = [outcomes.annotate(f) for f in ctx.findings]

    def _master(self) -> int | None:
        """The master, as the traffic shows it: the one node whose frames are only error control
        (and EMCY): no SDO answers, no TPDO, never addressed by SDO."""
        d = self.d
        counts = d.counts
        only = [n for n in d.nodes_seen() if counts[0x700 + n] and not counts[0x580 + n] and not counts[0x600 + n]
                and not any(counts[base + n] for base in (0x180, 0x280, 0x380, 0x480))]
        return only[0] if len(only) == 1 and d.nmt.commands else None

    def _check_config(self) -> None:
        d = self.d
        config = d.inputs.config
        if config is None:
            return
        seen = d.nodes_seen()
        configured = [n.node_id for n in config.nodes]
        if configured and not set(configured) & set(seen):
            raise DiagnoseError(
                f'config {d.inputs.config_source} does not match the trace {d.path}: it names node(s) '
                f'{", ".join(map(str, configured))}, the trace has frames from node(s) '
                f'{", ".join(map(str, seen)) or "none"}')
        for node in config.nodes:
            if node.node_id not in seen:
                d.ctx.add(Severity.WARNING, d.t0, node.node_id, f'configured node {node.name} sent no frame',
                          'it is off the bus, has another node id, or was not powered', 'config-node-missing')
        for node_id in seen:
            if node_id not in configured and node_id != config.master.node_id:  # not the master's heartbeat
                d.ctx.add(Severity.INFO, d.t0, node_id, 'node on the bus that the config does not name',
                          'another device on the bus (or a drive with a wrong node id)', 'config-node-extra')


def diagnose(recording: Recording, inputs: DiagnoseInputs | None = None,
             frames: Iterable[RawFrame] | None = None) -> Diagnosis:
    """One pass over ``frames`` (raw frames; default: the recording's) with the inputs' config and EDS."""
    engine = Engine(recording, inputs or DiagnoseInputs())
    return engine.run(recording.raw_frames() if frames is None else frames)
