"""PDOs: the mapping (learned from the trace's own 0x14xx-0x1Bxx SDO traffic, else the
config, else the EDS defaults, else CiA 402's predefined TPDO1/RPDO1), rates and ages, and
per-frame decoding of the objects other analysers follow (statusword, positions, ...)."""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from drive_bridge.bag.diagnose.identity import Identities
from drive_bridge.bag.diagnose.infer402 import Cia402Inference
from drive_bridge.bag.diagnose.model import Context, Severity
from drive_bridge.bag.diagnose.names import is_signed, object_label
from drive_bridge.bag.diagnose.sdo import SdoTransaction

if TYPE_CHECKING:  # canopen is imported when an EDS gives the mapping, not for every diagnosis
    from canopen.objectdictionary import ODVariable

AxisSink = Callable[[float, int, int, int], None]  # (t, node, axis slot, value)
CYCLIC_S = 0.5  # a PDO sent at least this often is cyclic: its silences are findings (not event PDOs')
SILENCE_FACTOR = 5.0  # a PDO silent this many mean intervals (and >= 0.1 s) is a gap
COMM = {0x1400: 'RPDO', 0x1800: 'TPDO'}
NOT_OPERATIONAL = {0x7F: 'pre-operational', 0x04: 'stopped'}  # NMT states in which a node ignores PDOs
GUESSED = ('CiA 402 predefined', 'inferred from the traffic')  # mappings of which only the first word is known
SLOWER = 1.1  # a SYNC-driven PDO this many SYNC periods apart on average is slower than SYNC


def _stored(variable: ODVariable) -> int:
    """A DCF's ParameterValue, else the EDS DefaultValue (0 when neither)."""
    value = variable.value if variable.value is not None else variable.default
    return int(value or 0)


def default_cob(kind: str, number: int, node: int) -> int | None:
    """The predefined connection set (PDOs 1..4)."""
    if number > 4:
        return None
    return (0x180 if kind == 'TPDO' else 0x200) + 0x100 * (number - 1) + node


def kind_of(cob: int) -> tuple[str, int, int] | None:
    """(kind, number, node) of a COB-ID of the predefined connection set."""
    if not 0x181 <= cob <= 0x57F or cob & 0x7F == 0:
        return None
    fc = cob >> 7
    return ('TPDO' if fc % 2 else 'RPDO'), (fc - 1) // 2, cob & 0x7F


@dataclass
class PdoChannel:
    node: int
    kind: str
    number: int
    cob_id: int | None
    entries: tuple[tuple[int, int, int], ...] = ()
    source: str = ''
    pending: dict[int, int] = field(default_factory=dict)  # mapping subindex -> raw entry
    count: int | None = None  # mapping subindex 0 as last seen
    disabled: int | None = None  # the COB-ID entry with bit 31 set (PDO not valid), as read or written

    def label(self) -> str:
        return f'{self.kind}{self.number} of node {self.node}'


@dataclass(slots=True)
class CobStats:
    count: int = 0
    first: float = 0.0
    last: float = 0.0
    max_gap: float = 0.0
    t_max_gap: float = 0.0
    sync_delay_sum: float = 0.0
    sync_delay_max: float = 0.0
    sync_delays: int = 0
    data: bytes | bytearray = b''
    first_sync: float = -1.0  # the last SYNC before its first frame
    not_operational: int = 0  # RPDO frames sent while the node was pre-operational or stopped
    first_not_operational: float = 0.0
    node_state: int = 0  # that state


class Pdos:
    def __init__(self, ctx: Context, identities: Identities, sinks: Mapping[int, AxisSink],
                 states: Mapping[int, int | None] | None = None) -> None:
        self.ctx = ctx
        self.identities = identities
        self.states = states if states is not None else {}  # node -> its NMT state as its heartbeat last said
        self.infer = Cia402Inference(ctx, self.configure, self._decode)
        self.sinks = sinks  # base index (slot 0) -> the analyser that follows the object
        self.channels: dict[tuple[int, str, int], PdoChannel] = {}
        self.by_cob: dict[int, PdoChannel] = {}
        self.stats: dict[int, CobStats] = {}
        self.decoders: dict[int, list[tuple[int, int, bool, AxisSink, int, int]]] = {}
        self.last_sync: float = -1.0
        self._resolved: set[int] = set()
        self._inferable: set[int] = set()  # COB-IDs of the predefined set whose mapping the traffic may tell
        self.register: Callable[[int], None] = lambda cob: None  # the engine routes a new COB-ID here

    # -- mapping ---------------------------------------------------------------------------
    def configure(self, node: int, kind: str, number: int, cob_id: int | None,
                  entries: tuple[tuple[int, int, int], ...], source: str) -> None:
        channel = self._channel(node, kind, number)
        if cob_id is not None:
            self._move(channel, cob_id)
        channel.entries = entries
        channel.source = source
        self._rebuild(channel)

    def _channel(self, node: int, kind: str, number: int) -> PdoChannel:
        key = (node, kind, number)
        channel = self.channels.get(key)
        if channel is None:
            channel = self.channels[key] = PdoChannel(node, kind, number, None)
            cob = default_cob(kind, number, node)
            if cob is not None:
                self._move(channel, cob)
        return channel

    def _move(self, channel: PdoChannel, cob_id: int) -> None:
        if channel.cob_id is not None and self.by_cob.get(channel.cob_id) is channel:
            del self.by_cob[channel.cob_id]
            self.decoders.pop(channel.cob_id, None)
        channel.cob_id = cob_id
        self.by_cob[cob_id] = channel
        self.register(cob_id)
        self._rebuild(channel)

    def _rebuild(self, channel: PdoChannel) -> None:
        if channel.cob_id is None:
            return
        od = self.ctx.nodes[channel.node].od if channel.node in self.ctx.nodes else None
        decoder = []
        bit = 0
        for index, sub, bits in channel.entries:
            base = 0x6000 + ((index - 0x6000) & 0x7FF) if 0x6000 <= index < 0xA000 else index
            sink = self.sinks.get(base)
            if sink is not None and bit % 8 == 0 and bits % 8 == 0 and bit + bits <= 64:
                decoder.append((bit // 8, bit // 8 + bits // 8, is_signed(od, index, sub), sink, channel.node,
                                (index - 0x6000) >> 11))
            bit += bits
        if decoder:
            self.decoders[channel.cob_id] = decoder
        else:
            self.decoders.pop(channel.cob_id, None)

    def sdo(self, txn: SdoTransaction) -> None:
        """Mapping and COB-IDs as the trace configures (or reads back) them."""
        index = txn.index
        if 0x6040 <= index < 0x6800 or (index == 0x1000 and (txn.value or 0) & 0xFFFF == 402):
            self.infer.hint(txn.node)
        if not 0x1400 <= index < 0x1C00:  # the value only for the PDO parameters (most SDOs are others)
            return
        value = txn.value
        if value is None:
            return
        kind = 'RPDO' if index < 0x1800 else 'TPDO'
        number = (index & 0x1FF) + 1
        channel = self._channel(txn.node, kind, number)
        if index & 0x200 == 0:  # communication parameter
            if txn.subindex == 1:
                channel.disabled = value if value & 0x80000000 else None
                self._move(channel, value & 0x7FF)
            return
        if txn.subindex == 0:
            channel.count = value
        else:
            channel.pending[txn.subindex] = value
        if channel.count is not None:
            raw = (channel.pending.get(s, 0) for s in range(1, channel.count + 1))
            channel.entries = tuple((v >> 16, (v >> 8) & 0xFF, v & 0xFF) for v in raw if v)
            channel.source = 'trace'
            self._rebuild(channel)
        self._resolved.discard(channel.cob_id or -1)

    def _fallback(self, cob: int) -> None:
        """A PDO frame of an unknown channel: the EDS defaults, else CiA 402's predefined PDO1."""
        self._resolved.add(cob)
        parsed = kind_of(cob)
        if parsed is None:
            return
        kind, number, node = parsed
        info = self.ctx.nodes.get(node)
        if info is not None and info.od is not None:
            od = info.od
            mapping = (0x1600 if kind == 'RPDO' else 0x1A00) + number - 1
            record = od.get(mapping)
            entries: tuple[tuple[int, int, int], ...] = ()
            from canopen.objectdictionary import ODArray, ODRecord
            if isinstance(record, (ODRecord, ODArray)):
                try:
                    count = _stored(record[0])
                    entries = tuple((v >> 16, (v >> 8) & 0xFF, v & 0xFF)
                                    for v in (_stored(record[s]) for s in range(1, count + 1)) if v)
                except (KeyError, TypeError, ValueError):
                    entries = ()
                if entries:
                    self.configure(node, kind, number, cob, entries, 'EDS default')
                    return
        ident = self.identities.nodes.get(node)
        if number == 1 and ident is not None and ident.profile == 402:
            self.configure(node, kind, 1, cob, ((0x6041 if kind == 'TPDO' else 0x6040, 0, 16),),
                           'CiA 402 predefined')
        elif info is None or info.family is None:
            self._inferable.add(cob)  # the inference looks at its frames

    # -- frames ----------------------------------------------------------------------------
    def frame(self, t: float, cob: int, data: bytes | bytearray) -> None:
        stats = self.stats.get(cob)
        if stats is None:
            stats = self.stats[cob] = CobStats(first=t, last=t)
        else:
            gap = t - stats.last
            if gap > stats.max_gap:
                stats.max_gap = gap
                stats.t_max_gap = stats.last
        stats.count += 1
        stats.last = t
        stats.data = data
        if stats.count == 1:
            stats.first_sync = self.last_sync
        if not cob & 0x80 and 0x200 <= cob < 0x580:  # RPDO ranges: the node ignores them unless operational
            state = self.states.get(cob & 0x7F)
            if state in NOT_OPERATIONAL:
                if not stats.not_operational:
                    stats.first_not_operational = t
                stats.not_operational += 1
                stats.node_state = state or 0
        if self.last_sync >= 0 and cob & 0x80:  # TPDO ranges: 0x180, 0x280, ...
            delay = t - self.last_sync
            stats.sync_delay_sum += delay
            stats.sync_delays += 1
            if delay > stats.sync_delay_max:
                stats.sync_delay_max = delay
        decoder = self.decoders.get(cob)
        if decoder is None:
            if cob not in self._resolved:
                self._fallback(cob)
                decoder = self.decoders.get(cob)
            if decoder is None:
                if cob in self._inferable and not self.infer.frame(t, cob, cob & 0x7F, bool(cob & 0x80), data):
                    self._inferable.discard(cob)
                return
        self._decode(t, cob, data)

    def _decode(self, t: float, cob: int, data: bytes | bytearray) -> None:
        decoder = self.decoders.get(cob)
        if decoder is None:
            return
        size = len(data)
        for start, end, signed, sink, node, slot in decoder:
            if end <= size:
                sink(t, node, slot, int.from_bytes(data[start:end], 'little', signed=signed))

    # -- results ---------------------------------------------------------------------------
    def finish(self, sync_period: float | None = None) -> None:
        self._disabled()
        for cob, stats in sorted(self.stats.items()):
            channel = self.by_cob.get(cob)
            if stats.not_operational:
                node = channel.node if channel else cob & 0x7F
                label = channel.label() if channel else f'PDO 0x{cob:03X}'
                self.ctx.add(Severity.WARNING, stats.first_not_operational, node,
                             f'{stats.not_operational} frame(s) of {label} (0x{cob:03X}) sent while the node was '
                             f'{NOT_OPERATIONAL[stats.node_state]}: it ignores them',
                             'the node was never started (NMT start, 0x01) or fell back; only an operational node '
                             'takes PDOs', 'pdo-not-operational',
                             short=f'PDOs sent to node {node} while {NOT_OPERATIONAL[stats.node_state]}')
            if sync_period and self.ctx.timing:
                self._slower_than_sync(cob, stats, channel, sync_period)
            if channel is not None and channel.entries and channel.source not in GUESSED:
                mapped = (sum(bits for _i, _s, bits in channel.entries) + 7) // 8
                if mapped != len(stats.data):
                    self.ctx.add(Severity.WARNING, stats.last, channel.node,
                                 f'{channel.label()} (0x{cob:03X}) carries {len(stats.data)} bytes, its mapping '
                                 f'({channel.source}) {mapped}',
                                 'the device maps other objects than assumed: give the config (or the mapping '
                                 'SDO traffic) the device really uses' if channel.source != 'trace' else
                                 'the device sends another length than it was configured to', 'pdo-length')
            if stats.count < 10 or not self.ctx.timing:
                continue
            mean = (stats.last - stats.first) / (stats.count - 1)
            if mean <= CYCLIC_S and stats.max_gap > max(SILENCE_FACTOR * mean, 0.1):
                channel = self.by_cob.get(cob)
                node = channel.node if channel else (cob & 0x7F)
                what = channel.label() if channel else f'PDO 0x{cob:03X}'
                self.ctx.add(Severity.WARNING, stats.t_max_gap, node,
                             f'{what} (0x{cob:03X}) silent {stats.max_gap:.2f} s (normally every {mean * 1000:.1f} ms)',
                             'the producer stopped (NMT state, no SYNC, or the node was off the bus)', 'pdo-gap')

    def _disabled(self) -> None:
        """PDOs the trace shows disabled (COB-ID bit 31 read or written) that then sent nothing: why no PDO came."""
        by_node: dict[int, list[PdoChannel]] = {}
        for channel in self.channels.values():
            if channel.disabled is not None and not self.stats.get(channel.cob_id or -1):
                by_node.setdefault(channel.node, []).append(channel)
        for node, channels in sorted(by_node.items()):
            channels.sort(key=lambda c: (c.kind, c.number))
            names = ', '.join(f'{c.kind}{c.number} (0x{c.disabled or 0:08X})' for c in channels)
            empty = [f'{c.kind}{c.number}' for c in channels if c.count == 0]
            mapping = f'; {", ".join(empty)} map(s) nothing (mapping subindex 0 = 0)' if empty else ''
            self.ctx.add(Severity.WARNING, self.ctx.t0, node,
                         f'{names} of node {node} disabled: COB-ID bit 31 set (PDO not valid){mapping}',
                         'these PDOs are not sent: enable them (clear bit 31 of 0x1800+n:1 / 0x1400+n:1 after '
                         'mapping them) in the config or the EDS', 'pdo-disabled',
                         short=f'PDOs of node {node} disabled')

    def _slower_than_sync(self, cob: int, stats: CobStats, channel: PdoChannel | None, period: float) -> None:
        """A PDO that follows SYNC (all of its frames soon after one) but not every SYNC."""
        if stats.count < 10 or stats.first_sync < 0 or stats.sync_delays < stats.count or \
                stats.sync_delay_max > 0.5 * period:
            return
        mean = (stats.last - stats.first) / (stats.count - 1)
        ratio = mean / period
        if ratio < SLOWER:
            return
        node = channel.node if channel else cob & 0x7F
        label = channel.label() if channel else f'PDO 0x{cob:03X}'
        every = round(ratio)
        if every >= 2 and abs(ratio - every) < 0.05 * every:
            self.ctx.add(Severity.INFO, stats.first, node,
                         f'{label} (0x{cob:03X}) comes every {every} SYNC ({mean * 1000:.1f} ms; SYNC every '
                         f'{period * 1000:.1f} ms)',
                         f'its transmission type is probably {every} (every {every}th SYNC)',
                         'pdo-rate')
            return
        missed = 1.0 - 1.0 / ratio
        self.ctx.add(Severity.WARNING, stats.first, node,
                     f'{label} (0x{cob:03X}) comes every {mean * 1000:.1f} ms on average, SYNC every '
                     f'{period * 1000:.1f} ms: {missed:.0%} of the SYNC cycles go without it',
                     'the producer skips cycles (busy, or its frames are lost) or is not SYNC-driven '
                     '(transmission type)', 'pdo-rate', short=f'{label} misses {missed:.0%} of the SYNC cycles')

    def rows(self) -> list[dict[str, Any]]:
        out = []
        for cob, stats in sorted(self.stats.items()):
            channel = self.by_cob.get(cob)
            duration = stats.last - stats.first
            row: dict[str, Any] = {
                'cob_id': f'0x{cob:03X}', 'pdo': channel.label() if channel else '', 'frames': stats.count,
                'rate_hz': (stats.count - 1) / duration if duration > 0 else 0.0,
                'max_age_s': stats.max_gap,
                'mean_after_sync_s': stats.sync_delay_sum / stats.sync_delays if stats.sync_delays else None,
                'mapping_source': channel.source if channel else 'unknown',
                'mapping': [], 'last_values': {}}
            if channel is not None:
                od = self.ctx.nodes[channel.node].od if channel.node in self.ctx.nodes else None
                bit = 0
                value = int.from_bytes(stats.data, 'little')
                for index, sub, bits in channel.entries:
                    label = object_label(od, index, sub)
                    row['mapping'].append(f'{label} ({bits} bit)')
                    if bit + bits <= 8 * len(stats.data):
                        raw = (value >> bit) & ((1 << bits) - 1)
                        if is_signed(od, index, sub) and raw >> (bits - 1):
                            raw -= 1 << bits
                        row['last_values'][label] = raw
                    bit += bits
            out.append(row)
        return out
