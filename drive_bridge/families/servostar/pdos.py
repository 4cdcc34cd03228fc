"""SERVOSTAR PDOs: a library chosen by number (0x2600-0x2603 receive, 0x2A00-0x2A03 transmit),
plus the free PDOs 37-40 whose mapping is written through 0x1600-0x1603 / 0x1A00-0x1A03
(shared/drives/servostar-400-600.md §2.5-2.8).

A configured PDO (the family's default or the config's own) whose mapping is a library PDO's
is selected by that number (the master writes the channel's selection object, then its COB-ID
and transmission type); any other mapping takes the channel's free PDO 36 + channel, selected
by a boot step before the master maps it freely. The mapping objects are read-only while a
library PDO is selected, so this order matters.

Default set, for the trajectory mode 0xFA (one absolute setpoint 0x2022:04 per SYNC):

======  ===========  =====================================================  =====  ======
PDO     library no.  objects                                                bytes  type
======  ===========  =====================================================  =====  ======
RPDO1   1            0x6040 controlword                                     2      1
RPDO2   38 (free)    0x2022:04 trajectory position setpoint                 4      1
TPDO1   23           0x6041 statusword, 0x1002 status register (DRVSTAT)    6      1
TPDO2   33           0x2070:03 incremental actual position, 0x2070:11       8      1
                     extended status
TPDO3   39 (free)    0x2070:02 speed (24 bit), 0x6061 mode display,          6      1
                     0x6077 torque
======  ===========  =====================================================  =====  ======

0x6060 (write-only) goes by SDO when the mode changes. Without SYNC every PDO is type 255 and
TPDO2 is the free PDO 38 with the same two objects (TPDO 33 is sent on SYNC only: a library
PDO whose transmission types exclude the configured one is mapped freely). Channel 4
and the ASCII PDO 21 (power-on RPDO2/TPDO2) are not used.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Final

from drive_bridge.cia301.cob import predefined_cob_id
from drive_bridge.families.servostar import objects as o
from drive_bridge.model import AxisConfig, PdoConfig, PdoEntry

SYNC_EVERY_CYCLE: Final = 1
EVENT_DRIVEN: Final = 255

Mapping_ = tuple[tuple[int, int, int], ...]  # (index, subindex, bits)

# library number -> mapping, as the manual's PDO tables print them (§2.6, §2.7); 21 (ASCII) and
# 41 (CAN master/slave, a single 0x2022:04 / 0x2070:13) are left out: a mapping of 0x2022:04
# alone is the free PDO the trajectory mode uses
RPDO_LIBRARY: Final[Mapping[int, Mapping_]] = {
    1: ((0x6040, 0, 16),),
    22: ((0x6040, 0, 16), (0x2060, 0, 32)),
    32: ((0x2060, 0, 32),),
    33: ((0x2022, 4, 32), (0x2022, 4, 32)),
    34: ((0x2022, 1, 32), (0x2022, 2, 16), (0x2022, 3, 16)),
    35: ((0x2022, 5, 16),),
}
TPDO_LIBRARY: Final[Mapping[int, Mapping_]] = {
    1: ((0x6041, 0, 16),),
    22: ((0x6041, 0, 16), (0x2070, 1, 24), (0x2070, 2, 24)),
    23: ((0x6041, 0, 16), (0x1002, 0, 32)),
    32: ((0x2070, 1, 24), (0x2070, 2, 24)),
    33: ((0x2070, 3, 32), (0x2070, 0x11, 32)),
    34: ((0x2086, 0, 16),),
}
# transmission types a library PDO takes (§2.5): None = any
ONLY_ASYNC: Final = frozenset({255})
ONLY_SYNC: Final = frozenset(range(1, 241))
RPDO_TYPES: Final[Mapping[int, frozenset[int]]] = {33: frozenset(range(0, 241)), 34: ONLY_ASYNC, 35: ONLY_ASYNC}
TPDO_TYPES: Final[Mapping[int, frozenset[int]]] = {32: ONLY_SYNC, 33: ONLY_SYNC}


def _key(config: PdoConfig) -> Mapping_:
    return tuple((e.index, e.subindex, e.bits) for e in config.mapping)


def library_number(kind: str, config: PdoConfig) -> int | None:
    """The library PDO whose mapping ``config`` has and whose transmission types include the
    config's (kind 'RPDO' / 'TPDO'); None: a free PDO (e.g. TPDO 33's objects event-driven)."""
    library = RPDO_LIBRARY if kind == 'RPDO' else TPDO_LIBRARY
    types = RPDO_TYPES if kind == 'RPDO' else TPDO_TYPES
    mapping = _key(config)
    for number, entries in library.items():
        allowed = types.get(number)
        if entries == mapping and (allowed is None or config.transmission in allowed):
            return number
    return None


def free_number(config: PdoConfig) -> int:
    """The free PDO a channel takes for a mapping of its own: 36 + channel (37..40)."""
    return o.FREE_PDOS[config.number - 1]


def select_index(kind: str, config: PdoConfig) -> int:
    return (o.RPDO_SELECT if kind == 'RPDO' else o.TPDO_SELECT) + config.number - 1


def select_writes(kind: str, config: PdoConfig) -> tuple[tuple[int, int, int], ...] | None:
    """The selection write of a library PDO, None for a free one (mapped by the master)."""
    number = library_number(kind, config)
    return None if number is None else ((select_index(kind, config), 0, number),)


def _entry(key: tuple[int, int], bits: int) -> PdoEntry:
    return PdoEntry(key[0], key[1], bits)


def default_pdos(node_id: int, axes: Sequence[AxisConfig],
                 synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
    if len(axes) > 1:
        raise ValueError(f'a SERVOSTAR drives one axis, {len(axes)} given')
    kind = SYNC_EVERY_CYCLE if synchronous else EVENT_DRIVEN

    def pdo(direction: str, number: int, *entries: PdoEntry) -> PdoConfig:
        return PdoConfig(number, predefined_cob_id(direction, number, node_id), transmission=kind,
                         mapping=tuple(entries))
    rpdos = (pdo('rpdo', 1, _entry((o.CONTROLWORD, 0), 16)),
             pdo('rpdo', 2, _entry(o.TRAJECTORY_SETPOINT, 32)))
    tpdos = (pdo('tpdo', 1, _entry((o.STATUSWORD, 0), 16), _entry((o.STATUS_REGISTER, 0), 32)),
             pdo('tpdo', 2, _entry(o.ACTUAL_POSITION, 32), _entry(o.EXTENDED_STATUS, 32)),
             pdo('tpdo', 3, _entry(o.ACTUAL_SPEED, 24), _entry((o.MODES_DISPLAY, 0), 8), _entry(o.TORQUE_ACTUAL, 16)))
    return rpdos, tpdos


def check_pdos(rpdos: Sequence[PdoConfig], tpdos: Sequence[PdoConfig]) -> list[str]:
    """The SERVOSTAR's PDO rules the EDS cannot say."""
    problems: list[str] = []
    for kind, configs in (('RPDO', rpdos), ('TPDO', tpdos)):
        for config in configs:
            where = f'{kind}{config.number}'
            if not 1 <= config.number <= o.CHANNELS:
                problems.append(f'{where}: the SERVOSTAR has {o.CHANNELS} {kind} channels (1..{o.CHANNELS})')
                continue
            if not config.enabled:
                continue
            number = library_number(kind, config)
            if number is None:
                if len(config.mapping) > o.MAX_FREE_ENTRIES or config.bits > 64:
                    problems.append(f'{where}: a free PDO ({free_number(config)}) takes at most '
                                    f'{o.MAX_FREE_ENTRIES} objects and 8 bytes')
                if any(0x3500 <= e.index <= 0x39FF for e in config.mapping):
                    problems.append(f'{where}: object-channel objects (0x3500+) cannot be mapped')
                continue
            if kind == 'RPDO' and number == 33:
                problems.append(f'{where}: library PDO 33 (two drives in one frame) is not supported by the '
                                'bridge; map 0x2022:04 alone (a free PDO)')
    return problems
