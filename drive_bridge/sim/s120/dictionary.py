"""The simulated S120's object dictionary as the drive has it at construction [1.4]: the
Predefined Connection Set's mapping in PDO 1..4 of every drive object whose EDS leaves them
empty, invalid COB-IDs for the PDOs of every drive object but the first, and the limits the
V4.8 EDS inverts relaxed."""
from __future__ import annotations

import copy

from drive_bridge.cia402 import objects as obj
from drive_bridge.sim.pdocodec import COB_INVALID
from drive_bridge.sim.store import ObjectStore, key

PDO_OFFSET = 0x40  # PDO parameters per slot

# the Predefined Connection Set of every drive object (Tab. 2-3, 2-4; + 0x800 per slot)
RPDO_MAPS = {1: (0x60400010,), 2: (0x60400010, 0x60FF0020), 3: (0x60400010, 0x60710010),
             4: (0x60400010, 0x60FF0020, 0x60710010)}
TPDO_MAPS = {1: (0x60410010,), 2: (0x60410010, 0x606C0020), 3: (0x60410010, 0x60770010),
             4: (0x60410010, 0x60630020)}


def relax_inverted_limits(store: ObjectStore) -> None:
    """Limits the EDS gives as unsigned hex for a signed object (the V4.8 file's 0x6871:
    0x0000..0xFFFF, read as 0..-1) mean the whole range: the drive takes every value."""
    for k, var in list(store.variables.items()):
        if var.min is not None and var.max is not None and var.min > var.max:
            relaxed = copy.copy(var)
            relaxed.min = relaxed.max = None
            store.variables[k] = relaxed


def predefined_connection_set(store: ObjectStore, slots: int) -> None:
    """PDO 1..4 of each of ``slots`` drive objects mapped as Tab. 2-3/2-4 where the EDS maps nothing."""
    for slot in range(slots):
        for base, maps in ((0x1600, RPDO_MAPS), (0x1A00, TPDO_MAPS)):
            for number, entries in maps.items():
                index = base + PDO_OFFSET * slot + number - 1
                subs = [key(index, s) for s in range(len(entries) + 1)]
                if not all(k in store for k in subs) or any(
                        store.defaults.get(k) for k in store.keys_between(index, index)):
                    continue  # no such PDO, or the EDS maps it already
                shifted = [e + ((obj.AXIS_OFFSET * slot) << 16) for e in entries]
                if not all(key(e >> 16, e >> 8 & 0xFF) in store for e in shifted):
                    continue  # an object the EDS lacks (e.g. no 0x6077 in the flat file)
                for sub, entry in enumerate(shifted, 1):
                    store.set_default(index, sub, entry)
                store.set_default(index, 0, len(shifted))


def invalid_cob_ids(store: ObjectStore, slots: int) -> None:
    """Only the first drive object has predefined COB-IDs [1.4]: the others start invalid."""
    for slot in range(1, slots):
        for base in (0x1400, 0x1800):
            for number in range(8):
                k = key(base + PDO_OFFSET * slot + number, 1)
                if k in store and not store.defaults[k] & COB_INVALID:
                    store.set_default(base + PDO_OFFSET * slot + number, 1, store.defaults[k] | COB_INVALID)
