"""The AKD's PDO rules on top of CiA 301's [2.4, 10.12]: transmission types 0..240 and 255
only; RPDO type n applies its data at every n-th SYNC, RPDOs due at one SYNC in COB-ID order;
mapping refused in OPERATIONAL (0x08000022, "map before NMT start") but, before that, the
mapping and COB-ID of a valid PDO may be changed directly; event-driven TPDO1..4 filtered by
the change masks 0x2014..0x2017; TPDO values that differ from SDO (0x606C in rpm)."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from canopen.objectdictionary import ODVariable
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.akd.objects import ABORT_INVALID_VALUE, ABORT_STATE, CHANGE_MASKS
from drive_bridge.sim.pdo import PdoEngine
from drive_bridge.sim.pdocodec import COB_INVALID, Pdo


class AkdPdoEngine(PdoEngine):
    """The AKD's PDO rules (module docstring)."""

    change_masks = CHANGE_MASKS

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.operational: Callable[[], bool] = lambda: False
        self.pdo_readers: dict[int, Callable[[], Any]] = {}  # values a TPDO sends differently from SDO

    def validate(self, index: int, subindex: int, value: int) -> None:
        pdo = self.by_index[index]
        if index == pdo.mapping and self.operational():
            raise SdoAbortedError(ABORT_STATE)
        if index == pdo.comm and subindex == 2 and not (value <= 240 or value == 255):
            raise SdoAbortedError(ABORT_INVALID_VALUE)
        super().validate(index, subindex, value)

    def mapping_locked(self, pdo: Pdo, cob: int) -> bool:
        return self.operational() and not cob & COB_INVALID

    def value_getter(self, k: int, var: ODVariable) -> Callable[[], Any]:
        reader = self.pdo_readers.get(k)
        return reader if reader is not None else super().value_getter(k, var)

    def due_rpdos(self) -> list[Pdo]:
        """Synchronous RPDOs due at this SYNC (type n: every n-th), in COB-ID order."""
        due = []
        for cob in sorted(self.rx_by_cob):
            pdo = self.rx_by_cob[cob]
            if not pdo.synchronous:
                continue
            pdo.sync_count += 1
            if pdo.trans_type and pdo.sync_count < pdo.trans_type:
                continue
            pdo.sync_count = 0
            due.append(pdo)
        return due

