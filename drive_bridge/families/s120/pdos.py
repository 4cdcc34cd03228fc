"""The S120's default PDO map, the COB-IDs of its further drive objects, and its PDO limits.

Default map, per axis slot ``s`` (PDO numbers 64 * s + 1 and 64 * s + 2, i.e. the first two
PDOs of the drive object's block at 0x1400/0x1600/0x1800/0x1A00 + 0x40 * s):

======  ===================================================================  =====
PDO     objects (each at +0x800 * s)                                         bits
======  ===================================================================  =====
RPDO a  0x6040 controlword, 0x6060 modes of operation, 0x6071 target torque,  56
        0x6042 vl target velocity (rpm, INTEGER16)
RPDO b  0x60FF target velocity (PV; the bridge's position loop too)           32
TPDO a  0x6041 statusword, 0x6061 modes of operation display,                 40
        0x6077 torque actual
TPDO b  0x6063 position actual (r0482), 0x606C velocity actual                64
======  ===================================================================  =====

An object the node's EDS does not have, or has but does not let map (the flat 2012 EDS:
0x6060 is not PDO-mappable, 0x6042 and 0x6077 are missing), is left out: 0x6060 then goes by SDO, which
is also the way the manual recommends for a mode change (§7). Transmission type 1 (every
SYNC: the drive applies an RPDO received after SYNC k at SYNC k+1) when the bridge sends
SYNC, else 254 with a 10 ms event timer for the TPDOs.

COB-IDs. Only the first drive object has predefined COB-IDs (Tab. 2-3/2-4); the manual leaves
the others to the master (§1.4). The scheme is deterministic and uses, per pair of slots, the
predefined connection set of one node id:

- slot 2j   -> RPDO 0x200 / 0x300 + (id + j),  TPDO 0x180 / 0x280 + (id + j),
- slot 2j+1 -> RPDO 0x400 / 0x500 + (id + j),  TPDO 0x380 / 0x480 + (id + j).

So a node with one or two drive objects stays inside its own node id's predefined set: no
other node's default PDOs can clash with it, whatever the bus. Slots 2..7 take the set of the
node ids id + 1 .. id + 3, which must then be free on the bus (the loader's bus-wide COB-ID check
names a clash); a slot whose node id would pass 127 has no default (give cob_id). Every default
COB-ID is within the drive's range 0x001..0x6DF. At boot the bridge first invalidates any other
PDO of the node that still holds one of these COB-IDs (slot 0's RPDO/TPDO 3 and 4 are valid by
default with 0x400/0x500/0x380/0x480 + id).

Limits (§2.4, §2.7.3): at most 8 RPDOs and 8 TPDOs per drive object (the first 8 numbers of its
block of 64), at most 4 mapped objects per PDO, at most 25 valid RPDOs on one CU (A08758), and
COB-IDs up to 0x6DF. :func:`check_pdos` names the limit a configuration passes.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

from drive_bridge.cia301.cob import predefined_cob_id
from drive_bridge.cia402 import objects as cia
from drive_bridge.families.s120 import objects as s
from drive_bridge.model import AxisConfig, PdoConfig, PdoEntry

SYNC_EVERY_CYCLE = 1
EVENT_DRIVEN = 254
EVENT_TIMER_MS = 10
MAX_NODE_ID = 127

Mappable = Callable[[int], bool]  # is this object (absolute index, sub 0) in the EDS and PDO-mappable?


def _always(_index: int) -> bool:
    return True


def cob_ids(node_id: int, slot: int) -> tuple[tuple[int, int], tuple[int, int]]:
    """((RPDO a, RPDO b), (TPDO a, TPDO b)) COB-IDs of ``slot``'s default PDOs; ValueError when
    the slot would need a node id above 127."""
    owner = node_id + slot // 2
    if owner > MAX_NODE_ID:
        raise ValueError(f'axis slot {slot} would take the predefined COB-IDs of node id {owner} (> 127); '
                         'give the node explicit rpdo/tpdo with cob_id')
    first = 1 if slot % 2 == 0 else 3
    return ((predefined_cob_id('rpdo', first, owner), predefined_cob_id('rpdo', first + 1, owner)),
            (predefined_cob_id('tpdo', first, owner), predefined_cob_id('tpdo', first + 1, owner)))


def _entries(slot: int, mappable: Mappable, *objects: tuple[int, int]) -> tuple[PdoEntry, ...]:
    found = []
    for index, bits in objects:
        absolute = cia.for_axis(index, slot)
        if mappable(absolute):
            found.append(PdoEntry(absolute, 0, bits))
    return tuple(found)


def default_pdos(node_id: int, axes: Sequence[AxisConfig], synchronous: bool,
                 mappable: Mappable = _always) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
    """(RPDOs, TPDOs) of the module docstring for the node's axes."""
    rx_type = SYNC_EVERY_CYCLE if synchronous else EVENT_DRIVEN
    tx_type = SYNC_EVERY_CYCLE if synchronous else EVENT_DRIVEN
    timer = 0 if synchronous else EVENT_TIMER_MS
    rpdos: list[PdoConfig] = []
    tpdos: list[PdoConfig] = []
    for axis in sorted(axes, key=lambda a: a.slot):
        slot = axis.slot
        (rx_a, rx_b), (tx_a, tx_b) = cob_ids(node_id, slot)
        first, second = s.pdo_number(slot, 0), s.pdo_number(slot, 1)
        rx_maps = ((first, rx_a, _entries(slot, mappable, (cia.CONTROLWORD, 16), (cia.MODES_OF_OPERATION, 8),
                                          (cia.TARGET_TORQUE, 16), (s.VL_TARGET_VELOCITY, 16))),
                   (second, rx_b, _entries(slot, mappable, (cia.TARGET_VELOCITY, 32))))
        tx_maps = ((first, tx_a, _entries(slot, mappable, (cia.STATUSWORD, 16), (cia.MODES_OF_OPERATION_DISPLAY, 8),
                                          (cia.TORQUE_ACTUAL, 16))),
                   (second, tx_b, _entries(slot, mappable, (s.POSITION_ACTUAL, 32), (cia.VELOCITY_ACTUAL, 32))))
        rpdos += [PdoConfig(n, cob, transmission=rx_type, mapping=m) for n, cob, m in rx_maps if m]
        tpdos += [PdoConfig(n, cob, transmission=tx_type, event_timer=timer, mapping=m) for n, cob, m in tx_maps if m]
    return tuple(rpdos), tuple(tpdos)


def _label(kind: str, config: PdoConfig) -> str:
    slot, k = s.slot_of_pdo(config.number)
    return f'{kind} {config.number} (PDO {k + 1} of the drive object in slot {slot})'


def check_pdos(rpdos: Iterable[PdoConfig], tpdos: Iterable[PdoConfig], slots: Iterable[int] = ()) -> list[str]:
    """The S120's PDO limits a node's PDO configuration breaks, each naming the limit.
    ``slots``: the node's configured axis slots (a PDO of another drive object is named)."""
    problems: list[str] = []
    configured = set(slots)
    valid_rx = 0
    for kind, configs in (('RPDO', list(rpdos)), ('TPDO', list(tpdos))):
        for config in configs:
            slot, k = s.slot_of_pdo(config.number)
            if slot >= s.MAX_DRIVE_OBJECTS or k >= s.PDOS_PER_SLOT:
                problems.append(f'{kind} {config.number}: a drive object has at most {s.PDOS_PER_SLOT} {kind}s, '
                                f'numbered 64 x slot + 1..8 (slot {slot}: {s.pdo_number(slot, 0)}..'
                                f'{s.pdo_number(slot, s.PDOS_PER_SLOT - 1)})')
                continue
            if configured and slot not in configured:
                problems.append(f'{_label(kind, config)}: no axis of the node is in slot {slot}')
            if len(config.mapping) > s.MAX_PDO_ENTRIES:
                problems.append(f'{_label(kind, config)}: {len(config.mapping)} objects mapped; an S120 PDO '
                                f'carries at most {s.MAX_PDO_ENTRIES}')
            if config.enabled and config.cob_id > s.COB_ID_MAX:
                problems.append(f'{_label(kind, config)}: COB-ID 0x{config.cob_id:03X} is above the highest the '
                                f'drive takes (0x{s.COB_ID_MAX:03X})')
            if kind == 'RPDO' and config.enabled:
                valid_rx += 1
    if valid_rx > s.MAX_VALID_RPDOS:
        problems.append(f'{valid_rx} valid RPDOs; one S120 Control Unit receives at most {s.MAX_VALID_RPDOS} valid '
                        'RPDOs over all its drive objects (alarm A08758): disable some or shrink the map')
    return problems
