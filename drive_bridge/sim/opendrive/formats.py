"""The simulated OPEN drive's read-only domains that describe its tables: the format words of
every P and C parameter (Tab_formati, Tab_con_formati, Tab_formati_extra), the representation
words of the actual values (Tab_exp_int, Tab_exp_osc), the factory tables (Tab_par_def,
Tab_con_def) and the monitor buffers."""
from __future__ import annotations

import struct
from collections.abc import Callable, Mapping

from drive_bridge.families.opendrive.parameter_table import CONNECTIONS, EXTRA, PARAMETERS, Parameter
from drive_bridge.sim.opendrive import objects as o


def words(values: list[int]) -> bytes:
    """INT16/UINT16 words, little-endian."""
    return struct.pack(f'<{len(values)}H', *(w & 0xFFFF for w in values))


def format_domains(factory_par: list[int], factory_con: list[int],
                   representation: Callable[[int], int]) -> dict[int, bytes]:
    """The domains by index; ``representation(element)`` gives an actual value's word."""
    def table(entries: Mapping[int, Parameter], count: int) -> bytes:
        data: list[int] = []
        for number in range(count):
            entry = entries.get(number)
            data += entry.words() if entry is not None else [0, 0, 0, 0]
        return words(data)

    extra: list[int] = []
    for number in range(100):
        extra += list(EXTRA.get(number, (0, 0, 0, 0, 0)))
    representations = words([representation(e) for e in range(64)])
    monitor = bytes(2 * o.MONITOR_POINTS)
    return {o.TAB_FORMATI: table(PARAMETERS, 200), o.TAB_CON_FORMATI: table(CONNECTIONS, 100),
            o.TAB_EXP_INT: representations, o.TAB_EXP_OSC: representations,
            o.TAB_PAR_DEF: words(factory_par), o.TAB_CON_DEF: words(factory_con),
            o.TAB_MONITOR_A: monitor, o.TAB_MONITOR_B: monitor, o.TAB_FORMATI_EXTRA: words(extra)}
