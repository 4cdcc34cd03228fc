"""The bus budget: can the bus carry the cyclic traffic the configuration asks for?

Per cycle the bridge sends SYNC and every enabled RPDO (one that carries interpolation data
only for a node with an axis in ip); each synchronous TPDO comes back
every n-th SYNC (transmission type n), an acyclic or event-driven one at most once per
cycle (less with an inhibit time); heartbeats and node guarding come on top at their own
period. Bits per frame are the classic CAN frame with worst-case bit stuffing
(docs/python-ecosystem.md §5): 47 + 8 n + ⌊(33 + 8 n) / 4⌋ for n data bytes. A design
keeps under 70 % to leave room for SDO, EMCY and retries.
"""
from __future__ import annotations

from dataclasses import dataclass

from drive_bridge.cia301.busbits import frame_bits
from drive_bridge.cia402.bootmodes import has_mode
from drive_bridge.families import get_family
from drive_bridge.model import BusConfig, MasterConfig, ModeChoice, NodeConfig, PdoConfig

WARN_LOAD = 0.70
INTERPOLATED_POSITION = 7


@dataclass(frozen=True)
class BusBudget:
    """The cyclic traffic of a configuration against its bit rate (rates per cycle and per second)."""

    period: float  # s, the cycle the rates are counted over
    bitrate: int | None
    frames_per_cycle: float
    bits_per_cycle: float  # cycle-bound frames only (SYNC, RPDOs, TPDOs)
    background_bits_per_second: float  # heartbeats, node guarding
    parts: tuple[tuple[str, float], ...]  # (what, frames per cycle)

    @property
    def bits_per_second(self) -> float:
        return self.bits_per_cycle / self.period + self.background_bits_per_second

    @property
    def frames_per_second(self) -> float:
        return self.frames_per_cycle / self.period

    @property
    def load(self) -> float | None:
        """Fraction of the bit rate; None when the bit rate is left to the interface."""
        return self.bits_per_second / self.bitrate if self.bitrate else None

    def period_for(self, load: float) -> float | None:
        """The shortest cycle at which the load stays at ``load`` (None: not with these maps)."""
        if not self.bitrate:
            return None
        room = load * self.bitrate - self.background_bits_per_second
        return self.bits_per_cycle / room if room > 0 else None

    def describe(self) -> str:
        parts = ', '.join(f'{_count(n)} {what}' for what, n in self.parts if n)
        load = self.load
        figure = f'{load:.0%} of {self.bitrate / 1000:g} kbit/s' if load is not None and self.bitrate else 'unknown'
        return (f'bus load {figure}: {_count(self.frames_per_cycle)} frames every {self.period * 1000:g} ms '
                f'cycle ({parts}), {self.frames_per_second:.0f} frames/s, {self.bits_per_second / 1000:.0f} kbit/s '
                'with worst-case bit stuffing')


def _count(n: float) -> str:
    return f'{n:g}' if n == int(n) else f'{n:.2f}'


def _tpdo_per_cycle(pdo: PdoConfig, period: float) -> float:
    if 1 <= pdo.transmission <= 240:
        return 1.0 / pdo.transmission
    if pdo.inhibit_time:  # x100 µs: at most one frame per inhibit time, and once per cycle
        return min(1.0, period / (pdo.inhibit_time * 1e-4))
    return 1.0  # acyclic or on change: once per cycle in the worst case


def _idle(node: NodeConfig, pdo: PdoConfig) -> bool:
    """An RPDO sent only when written (the interpolation data of ip), on a node with no axis
    that can run ip (configured, or among the modes picked at boot)."""
    family = get_family(node.family)
    if not any(family.sent_on_write(e.index, e.subindex) for e in pdo.mapping):
        return False
    return not any(INTERPOLATED_POSITION in (a.mode, a.position_mode) or _may_pick_ip(a.auto_mode)
                   for a in node.axes)


def _may_pick_ip(auto: ModeChoice | None) -> bool:
    """The boot will pick ip: the first of a derived map's candidates the drive supports (as
    far as the EDS tells; 0x6502 is read at boot). Explicit PDOs (candidates None) are counted
    for the modes the user named."""
    if auto is None or not auto.candidates:
        return False
    first = next((m for m in auto.candidates if has_mode(auto.inferred_support, m)), None)
    return first == INTERPOLATED_POSITION


def _background(master: MasterConfig, nodes: tuple[NodeConfig, ...]) -> tuple[float, float]:
    """(frames/s, bits/s) of heartbeats and node guarding."""
    frames = bits = 0.0
    if master.heartbeat_producer_ms:
        frames += 1000.0 / master.heartbeat_producer_ms
        bits += frame_bits(1, stuffed=True) * 1000.0 / master.heartbeat_producer_ms
    for node in nodes:
        if node.guarding:  # remote request of the master, then the node's 1-byte answer
            rate = 1000.0 / node.guard_time_ms
            frames += 2 * rate
            bits += (frame_bits(0, remote=True, stuffed=True) + frame_bits(1, stuffed=True)) * rate
        elif node.heartbeat_producer_ms:
            frames += 1000.0 / node.heartbeat_producer_ms
            bits += frame_bits(1, stuffed=True) * 1000.0 / node.heartbeat_producer_ms
    return frames, bits


def bus_budget(bus_bitrate: int | None, master: MasterConfig, nodes: tuple[NodeConfig, ...]) -> BusBudget:
    """The budget of one bus (see the module docstring for what is counted)."""
    period = master.cycle_period
    sync = 1.0 if master.sends_sync else 0.0
    bits = sync * frame_bits(0, stuffed=True)
    rpdos = tpdos = 0.0
    for node in nodes:
        for pdo in node.rpdo:
            if pdo.enabled and not _idle(node, pdo):
                rpdos += 1
                bits += frame_bits((pdo.bits + 7) // 8, stuffed=True)
        for pdo in node.tpdo:
            if pdo.enabled:
                n = _tpdo_per_cycle(pdo, period)
                tpdos += n
                bits += n * frame_bits((pdo.bits + 7) // 8, stuffed=True)
    background_frames, background_bits = _background(master, nodes)
    parts = (('SYNC', sync), ('RPDO', rpdos), ('TPDO', tpdos),
             ('heartbeat/guarding', background_frames * period))
    return BusBudget(period, bus_bitrate, sum(n for _, n in parts), bits, background_bits, parts)


def budget_of(config: BusConfig) -> BusBudget:
    return bus_budget(config.bus.bitrate, config.master, config.nodes)


def budget_verdict(budget: BusBudget, allow_overload: bool,
                   period_key: str = 'master.sync_period') -> tuple[str | None, str | None]:
    """(warning, error) texts for the configuration check; both None when the load is fine.
    ``period_key`` names the setting the remedy tells to change (a ROS parameter may override it)."""
    load = budget.load
    if load is None:
        return (f'{budget.describe()}: bus.bitrate is null (left to the interface), so the budget is not checked',
                None)
    if load <= WARN_LOAD:
        return None, None
    shortest = budget.period_for(WARN_LOAD)
    remedy = (f'set {period_key} to at least {shortest * 1e6:.0f} µs' if shortest is not None
              else 'the heartbeats alone exceed it: lengthen heartbeat_producer')
    advice = (f'{remedy}, map fewer or smaller PDOs (a 6-byte TPDO instead of 8), raise bus.bitrate, '
              f'or split the nodes over two buses')
    if load > 1.0 and not allow_overload:
        fits = budget.period_for(1.0)
        limit = f' (it fits from {fits * 1e6:.0f} µs, with no room left)' if fits is not None else ''
        return None, (f'{budget.describe()}: the bus cannot carry it{limit}; {advice} '
                      '(bus.allow_overload: true runs it anyway, for experiments)')
    return f'{budget.describe()}: over {WARN_LOAD:.0%}, no room for SDO, EMCY and retries; {advice}', None
