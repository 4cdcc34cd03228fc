"""What the simulated SERVOSTAR keeps over a power cycle [2.9, 5.1]: SAVE (35EBh) makes the
object channel's EEPROM parameters and the motion objects the power-on values; 0x1010:2 (only
with DRVCNFG bit 3; sub 1 is "reserved") stores the PDO configuration and communication
parameters, which come back at every reset of the communication."""
from __future__ import annotations

from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.servostar.objects import (
    ABORT_NOT_STORED,
    DRVCNFG,
    DRVCNFG_STORE_PDOS,
    SIGNATURE_SAVE,
    STORE_PARAMETERS,
    VALUE,
)
from drive_bridge.sim.store import ObjectStore, key

# communication parameters stored by 0x1010:2 (DRVCNFG bit 3) and restored at power-on
_COMM_RANGES = ((0x1005, 0x1007), (0x100C, 0x100E), (0x1014, 0x1014), (0x1400, 0x1BFF), (0x2600, 0x2603),
                (0x2A00, 0x2A03))
# parameters stored by SAVE (35EBh) besides the object channel's EEPROM entries
_SAVED_OBJECTS = (0x2020, 0x2024, 0x607B, 0x607C, 0x6086, 0x6098, 0x6099, 0x609A, 0x60C2)
IN_EEPROM = 0x00020000


class DriveStorage:
    """The drive's EEPROM; ``saved_comm``: what 0x1010:2 stored (None: never)."""

    def __init__(self, store: ObjectStore) -> None:
        self._store = store
        self.saved_comm: dict[int, Any] | None = None

    def register(self, reg: Any) -> None:
        """0x1010:1 and :2 through ``reg(index, subindex, **hooks)``."""
        reg(STORE_PARAMETERS, 1, validator=self._refuse_store)
        reg(STORE_PARAMETERS, 2, reader=lambda: 1, validator=self._check_store, on_write=lambda v: self._store_comm())

    def save(self) -> None:
        """SAVE (35EBh): the drive parameters in EEPROM become the power-on values."""
        values, defaults = self._store.values, self._store.defaults
        for k in self._store.variables:
            index, sub = k >> 8, k & 0xFF
            channel = 0x3500 <= index <= 0x39FF and sub == VALUE \
                and values.get(key(index, 6), 0) & IN_EEPROM
            if channel or index in _SAVED_OBJECTS:
                defaults[k] = values[k]

    @staticmethod
    def _refuse_store(value: int) -> None:
        raise SdoAbortedError(ABORT_NOT_STORED)  # 0x1010:1 is "reserved"

    def _check_store(self, value: int) -> None:
        if value != SIGNATURE_SAVE or not self._store.values.get(key(DRVCNFG, VALUE), 0) & DRVCNFG_STORE_PDOS:
            raise SdoAbortedError(ABORT_NOT_STORED)

    def _store_comm(self) -> None:
        """0x1010:2 "save" (with DRVCNFG bit 3): PDO configuration and communication parameters."""
        store = self._store
        self.saved_comm = {k: store.values[k] for low, high in _COMM_RANGES for k in store.keys_between(low, high)}
        store.values[key(STORE_PARAMETERS, 2)] = 1

    def load_communication(self) -> None:
        """The PDO configuration after power-on / reset: the library defaults, or what 0x1010:2
        stored when DRVCNFG bit 3 is set."""
        values, defaults = self._store.values, self._store.defaults
        for low, high in ((0x2600, 0x2603), (0x2A00, 0x2A03)):
            for k in self._store.keys_between(low, high):
                values[k] = defaults[k]
        if self.saved_comm and values.get(key(DRVCNFG, VALUE), 0) & DRVCNFG_STORE_PDOS:
            values.update(self.saved_comm)
