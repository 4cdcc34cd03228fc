"""The simulated OPEN drive's non-volatile memory: the P and C parameter tables and the
communication objects as saved, the factory values, and what 0x1010 / 0x1011 and C63 do to
them. Saved values load at power-on and reset node; a restore takes effect at the next
power-on."""
from __future__ import annotations

from typing import Any

from drive_bridge.families.opendrive.parameter_table import C52, C63, CONNECTIONS, P162, PARAMETERS
from drive_bridge.sim.opendrive import objects as o
from drive_bridge.sim.store import ObjectStore

COMMUNICATION_STATE = (0x1001, 0x1003, o.STORE_PARAMETERS, o.RESTORE_PARAMETERS)  # not saved by 0x1010


def int16_raw(value: int) -> int:
    """A table value as the INT16 array holds it."""
    value &= 0xFFFF
    return value - 0x10000 if value >= 0x8000 else value


class NonVolatileMemory:
    """``par`` / ``con``: the saved tables; ``factory_par`` / ``factory_con``: the factory tables."""

    def __init__(self, store: ObjectStore, node_id: int, c52: int) -> None:
        self._store = store
        self.factory_par = [0] * o.ARRAY_SIZES[o.TAB_PAR]
        self.factory_con = [0] * o.ARRAY_SIZES[o.TAB_CON]
        for p in PARAMETERS.values():
            self.factory_par[p.number] = int16_raw(p.default)
        for c in CONNECTIONS.values():
            self.factory_con[c.number] = int16_raw(c.default)
        self.factory_par[P162] = node_id
        self.factory_con[C52] = c52
        self.par, self.con = list(self.factory_par), list(self.factory_con)
        self._comm_keys = [k for k in store.variables
                           if 0x1000 <= k >> 8 <= 0x1FFF and k >> 8 not in COMMUNICATION_STATE]
        self._eds_comm: dict[int, Any] = {k: store.defaults[k] for k in self._comm_keys}
        self._comm = dict(self._eds_comm)

    def save_drive_parameters(self, tab_par: list[int], tab_con: list[int]) -> None:
        """C63 = 1 (or 0x1010:1): the tables as they are now; C63 is saved as 0."""
        self.par, self.con = list(tab_par), list(tab_con)
        self.con[C63] = 0

    def save(self, parameters: bool, tab_par: list[int], tab_con: list[int]) -> None:
        """0x1010: the communication objects (sub 1: and the drive parameters) to non-volatile
        memory; resets load them from then on."""
        values = self._store.values
        for k in self._comm_keys:
            self._comm[k] = self._store.defaults[k] = values[k]
        if parameters:
            self.save_drive_parameters(tab_par, tab_con)

    def restore(self, parameters: bool) -> None:
        """0x1011: the default communication objects (sub 1: and the factory drive parameters)
        are written to non-volatile memory; they take effect at the next power-on."""
        self._comm = dict(self._eds_comm)
        if parameters:
            self.par, self.con = list(self.factory_par), list(self.factory_con)

    def load_communication(self) -> None:
        """Power-on: the communication objects come from the non-volatile memory."""
        for k, value in self._comm.items():
            self._store.defaults[k] = value
