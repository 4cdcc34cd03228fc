"""The generic family's default process data, fitted to the drive's EDS.

Three tries, the first that carries what the bridge needs wins:

1. the drive's own default mapping (the PDOs its EDS enables by default), when it holds the
   controlword, the statusword, the position actual value and a streaming target, each output
   once;
2. the standard map (two RPDOs and two TPDOs per axis, RPDO 3 with 0x60C1:1), when every
   PDO and object of it exists, is mappable and fits;
3. a map fitted to the PDOs that exist: fixed mappings chosen by what they carry, free ones
   filled in order of need up to their sub-0 limit and 64 bits.

What no PDO carries is written by SDO (outputs), read by SDO at a lower rate (inputs), or,
for the velocity actual value, derived from the position (marked as estimated).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from canopen import ObjectDictionary

from drive_bridge.cia402 import objects as obj
from drive_bridge.families.generic402.eds import (
    MAX_PDO_BITS,
    Kind,
    ObjectKey,
    PdoSlot,
    bits_of,
    pdo_slots,
    variable,
    why_not_mappable,
)
from drive_bridge.families.generic402.modes import has_supported_modes, inferred_support, streamable
from drive_bridge.families.interface import PdoPlan
from drive_bridge.model import AxisConfig, ModeChoice, PdoConfig, PdoEntry

IP_POINT = (obj.INTERPOLATION_DATA_RECORD, 1)
# what the bridge wants in PDOs, most needed first, with the weight a fixed PDO scores for it
OUTPUTS: tuple[tuple[ObjectKey, int], ...] = (
    ((obj.CONTROLWORD, 0), 32), ((obj.TARGET_POSITION, 0), 16), (IP_POINT, 8), ((obj.TARGET_VELOCITY, 0), 4),
    ((obj.MODES_OF_OPERATION, 0), 2), ((obj.TARGET_TORQUE, 0), 1))
INPUTS: tuple[tuple[ObjectKey, int], ...] = (
    ((obj.STATUSWORD, 0), 32), ((obj.POSITION_ACTUAL, 0), 16), ((obj.MODES_OF_OPERATION_DISPLAY, 0), 8),
    ((obj.VELOCITY_ACTUAL, 0), 4), ((obj.TORQUE_ACTUAL, 0), 1))
DERIVED = (obj.VELOCITY_ACTUAL, 0)  # not polled: estimated from the position when unmapped
SYNC_EVERY_CYCLE = 1
EVENT_DRIVEN = 255

StandardMap = Callable[[], tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]]


def _at(key: ObjectKey, slot: int) -> ObjectKey:
    return obj.for_axis(key[0], slot), key[1]


def _is_ip_point(key: ObjectKey) -> bool:
    """0x60C1:1 of any axis slot: sent only in a cycle that writes it, so alone in its RPDO."""
    return key[1] == 1 and key[0] >= 0x6000 and (key[0] - IP_POINT[0]) % obj.AXIS_OFFSET == 0


def _name(key: ObjectKey) -> str:
    return f'{key[0]:04X}' + (f':{key[1]}' if key[1] else '')


@dataclass
class _Pdo:
    slot: PdoSlot
    keys: list[ObjectKey] = field(default_factory=list)
    bits: int = 0


class _Fit:
    """One kind's PDOs being filled."""

    def __init__(self, od: ObjectDictionary, kind: Kind, slots: list[PdoSlot]) -> None:
        self.od, self.kind, self.slots = od, kind, slots
        self.chosen: list[_Pdo] = []
        self.covered: set[ObjectKey] = set()
        self.reasons: dict[ObjectKey, str] = {}

    def _bits(self, key: ObjectKey) -> int:
        var = variable(self.od, key)
        return (bits_of(var) or 0) if var is not None else 0

    def usable(self, key: ObjectKey) -> bool:
        reason = why_not_mappable(self.od, key, self.kind)
        if reason:
            self.reasons.setdefault(key, reason)
        return not reason

    def take_fixed(self, wanted: dict[ObjectKey, int]) -> None:
        """Fixed mappings, best score first: an RPDO only if it carries nothing else and no
        output twice (a second copy would send stale values); a TPDO for what it adds."""
        candidates = [s for s in self.slots if s.fixed is not None]
        while candidates:
            def score(slot: PdoSlot) -> int:
                keys = slot.fixed or ()
                if not keys or not all(self.usable(k) for k in keys):
                    return 0
                if self.kind == 'rpdo' and (any(k not in wanted for k in keys) or self.covered & set(keys)):
                    return 0
                return sum(wanted.get(k, 0) for k in set(keys) - self.covered)
            best = max(candidates, key=score)
            if score(best) == 0:
                break
            candidates.remove(best)
            keys = list(best.fixed or ())
            self.chosen.append(_Pdo(best, keys, sum(self._bits(k) for k in keys)))
            self.covered |= set(keys)

    def fill_free(self, wanted: Sequence[ObjectKey]) -> None:
        """Free mappings in number order, first fit; 0x60C1:1 alone in its PDO (it is sent
        only in a cycle that writes it)."""
        free = [_Pdo(s) for s in self.slots if s.fixed is None]
        for key in wanted:
            if key in self.covered or not self.usable(key):
                continue
            bits = self._bits(key)
            for pdo in free:
                if len(pdo.keys) >= pdo.slot.room or pdo.bits + bits > MAX_PDO_BITS \
                        or any(_is_ip_point(k) for k in pdo.keys) or (_is_ip_point(key) and pdo.keys):
                    continue
                pdo.keys.append(key)
                pdo.bits += bits
                self.covered.add(key)
                break
            else:
                self.reasons.setdefault(key, 'no room in the PDOs the EDS has')
        self.chosen.extend(p for p in free if p.keys)
        self.chosen.sort(key=lambda p: p.slot.number)


def _configs(od: ObjectDictionary, pdos: Sequence[_Pdo], kind: Kind, synchronous: bool) -> tuple[PdoConfig, ...]:
    transmission = SYNC_EVERY_CYCLE if synchronous else EVENT_DRIVEN
    timer = 0 if synchronous or kind == 'rpdo' else 10
    configs = []
    for pdo in pdos:
        entries = []
        for key in pdo.keys:
            var = variable(od, key)
            entries.append(PdoEntry(key[0], key[1], (bits_of(var) or 0) if var is not None else 0))
        configs.append(PdoConfig(pdo.slot.number, pdo.slot.cob_id, transmission=transmission,
                                 event_timer=timer, mapping=tuple(entries)))
    return tuple(configs)


def _own_default(od: ObjectDictionary, node_id: int, slots: Sequence[int],
                 synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]] | None:
    """The PDOs the drive enables by default, when they carry what the bridge needs."""
    chosen: dict[Kind, list[_Pdo]] = {}
    for kind in ('rpdo', 'tpdo'):
        pdos = [_Pdo(s, list(s.default)) for s in pdo_slots(od, kind, node_id) if s.default_valid and s.default]
        keys = [k for p in pdos for k in p.keys]
        wanted = {_at(k, s) for s in slots for k, _ in (OUTPUTS if kind == 'rpdo' else INPUTS)}
        if any(why_not_mappable(od, k, kind) for k in keys):
            return None
        if kind == 'rpdo' and (len(keys) != len(set(keys)) or not set(keys) <= wanted):
            return None
        chosen[kind] = pdos
    rx = {k for p in chosen['rpdo'] for k in p.keys}
    tx = {k for p in chosen['tpdo'] for k in p.keys}
    for s in slots:
        targets = {_at(k, s) for k in ((obj.TARGET_POSITION, 0), IP_POINT, (obj.TARGET_VELOCITY, 0))}
        if _at((obj.CONTROLWORD, 0), s) not in rx or not targets & rx or \
                not {_at((obj.STATUSWORD, 0), s), _at((obj.POSITION_ACTUAL, 0), s)} <= tx:
            return None
    if any(len(p.keys) > 1 and any(_is_ip_point(k) for k in p.keys) for p in chosen['rpdo']):
        return None
    return _configs(od, chosen['rpdo'], 'rpdo', synchronous), _configs(od, chosen['tpdo'], 'tpdo', synchronous)


def _standard_fits(od: ObjectDictionary, node_id: int, rpdos: Sequence[PdoConfig],
                   tpdos: Sequence[PdoConfig]) -> str:
    """'' when the standard map can be written as it is, else the first reason it cannot."""
    for kind, configs in (('rpdo', rpdos), ('tpdo', tpdos)):
        slots = {s.number: s for s in pdo_slots(od, kind, node_id)}  # type: ignore[arg-type]
        for config in configs:
            slot = slots.get(config.number)
            if slot is None:
                return f'no {kind.upper()}{config.number}'
            if slot.fixed is not None and list(slot.fixed) != [(e.index, e.subindex) for e in config.mapping]:
                return f'{kind.upper()}{config.number} has a fixed mapping'
            if len(config.mapping) > slot.room:
                return f'{kind.upper()}{config.number} has room for {slot.room}'
            for entry in config.mapping:
                reason = why_not_mappable(od, (entry.index, entry.subindex), kind)  # type: ignore[arg-type]
                if reason:
                    return f'0x{_name((entry.index, entry.subindex))} {reason}'
    return ''


def _text(configs: Sequence[PdoConfig], kind: str) -> str:
    return ', '.join(f'{kind}{c.number} ' + '+'.join(_name((e.index, e.subindex)) for e in c.mapping)
                     for c in configs) or f'no {kind}'


def plan(od: ObjectDictionary, node_id: int, axes: Sequence[AxisConfig], synchronous: bool,
         standard: StandardMap, eds_name: str = 'the EDS') -> PdoPlan:
    """The default process data of a generic CiA 402 node (see the module docstring)."""
    slots = [a.slot for a in axes]
    why = 'the drive\'s own default mapping'
    maps = _own_default(od, node_id, slots, synchronous)
    reasons: dict[ObjectKey, str] = {}
    if maps is None:
        rpdos, tpdos = standard()
        problem = _standard_fits(od, node_id, rpdos, tpdos)
        why = 'the standard map'
        maps = (rpdos, tpdos)
        if problem:
            why = f'fitted to {eds_name}; the standard map does not fit: {problem}'
            fits: dict[Kind, _Fit] = {}
            for kind, wanted in (('rpdo', OUTPUTS), ('tpdo', INPUTS)):
                fit = _Fit(od, kind, pdo_slots(od, kind, node_id))  # type: ignore[arg-type]
                weights = {_at(k, s): w for s in slots for k, w in wanted}
                fit.take_fixed(weights)
                fit.fill_free([_at(k, s) for s in slots for k, _ in wanted])
                fits[kind] = fit  # type: ignore[index]
                reasons.update(fit.reasons)
            maps = (_configs(od, fits['rpdo'].chosen, 'rpdo', synchronous),
                    _configs(od, fits['tpdo'].chosen, 'tpdo', synchronous))
    rpdos, tpdos = maps
    rx = {(e.index, e.subindex) for c in rpdos for e in c.mapping}
    tx = {(e.index, e.subindex) for c in tpdos for e in c.mapping}
    exists = {_at(k, s) for s in slots for k, _ in (*OUTPUTS, *INPUTS) if variable(od, _at(k, s)) is not None}
    polled: list[ObjectKey] = []
    by_sdo: list[ObjectKey] = []
    derived: list[ObjectKey] = []
    planned_axes: list[AxisConfig] = []
    for axis in axes:
        s = axis.slot
        for key, _ in INPUTS:
            key = _at(key, s)
            if key in tx or key not in exists:
                continue
            (derived if key == _at(DERIVED, s) else polled).append(key)
        by_sdo.extend(_at(k, s) for k, _ in OUTPUTS if _at(k, s) not in rx and _at(k, s) in exists)
        estimated = _at(DERIVED, s) not in tx
        auto = axis.auto_mode
        if auto is not None:
            auto = ModeChoice(streamable(s, rx.__contains__, exists),
                              None if has_supported_modes(od, s) else inferred_support(od, s))
        planned_axes.append(replace(axis, estimated_velocity=estimated, auto_mode=auto))

    def listed(keys: Sequence[ObjectKey]) -> str:
        return ', '.join(f'{_name(k)} ({reasons.get(k, "not in the map")})' for k in keys) or 'nothing'
    summary = (f'PDO map ({why}): {_text(rpdos, "RPDO")}; {_text(tpdos, "TPDO")}; by SDO: {listed(by_sdo)}; '
               f'polled: {listed(polled)}'
               + (f'; estimated from position: {listed(derived)}' if derived else ''))
    return PdoPlan(rpdos, tpdos, tuple(planned_axes), tuple(polled), summary)
