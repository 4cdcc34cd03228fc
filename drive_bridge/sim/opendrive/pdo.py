"""The OPEN drive's PDO rules (§2.3, §2.4): TPDO type 0 is sent at *every* SYNC, 1-240
every n-th SYNC, 252 sampled at SYNC and sent on the next RTR, 253 sampled and sent on
RTR, 254 by the event timer only (no transmission on change), 255 firmware-defined (here:
CiA 301's event-driven behaviour); TPDO types 241-251 refused. RPDO 0-240 applied at the
next SYNC, 254 at once; 241-253 and 255 (not in the appendix's list) refused. Only sub 1 and
2 of 0x1400-0x1403 exist. The appendix's mapping procedure (sub 0 = 0, entries, sub 0 = n)
is accepted with or without invalidating the PDO first, and a valid PDO's COB-ID may be
changed (the appendix asks for neither)."""
from __future__ import annotations

import time
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.opendrive.objects import ABORT_INVALID_VALUE
from drive_bridge.sim.pdo import PdoEngine
from drive_bridge.sim.pdocodec import Pdo
from drive_bridge.sim.pdoparams import COB_NO_RTR
from drive_bridge.sim.store import key

RTR_SAMPLED, RTR_NOW, EVENT_TIMER = 252, 253, 254


class OpenDrivePdoEngine(PdoEngine):
    """The OPEN drive's PDO rules (module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.sampled: dict[int, bytes] = {}  # TPDO number -> data sampled at the last SYNC (type 252)

    def validate(self, index: int, subindex: int, value: int) -> None:
        pdo = self.by_index[index]
        if index == pdo.comm and subindex == 2:
            reserved = 241 <= value <= 251 if pdo.transmit else 241 <= value <= 253 or value == 255
            if reserved:
                raise SdoAbortedError(ABORT_INVALID_VALUE)
            return
        super().validate(index, subindex, value)

    def mapping_locked(self, pdo: Pdo, cob: int) -> bool:
        return False

    def acyclic_due(self, pdo: Pdo, data: bytes) -> bool:
        return True  # type 0: at every SYNC

    def has_changed(self, pdo: Pdo, data: bytes) -> bool:
        if pdo.transmit and pdo.trans_type == EVENT_TIMER:
            return False  # time-triggered only
        return super().has_changed(pdo, data)

    def written(self, index: int) -> None:
        pdo = self.by_index[index]
        self.sampled.pop(pdo.number if pdo.transmit else -1, None)
        super().written(index)

    def transmit_on_sync(self, counter: int | None) -> None:
        super().transmit_on_sync(counter)
        if self.tpdo_allowed():
            for pdo in self.tpdos.values():
                if pdo.valid and pdo.trans_type == RTR_SAMPLED:
                    self.sampled[pdo.number] = self.packed(pdo)

    def remote_cob_ids(self) -> set[int]:
        """COB-IDs of the valid TPDOs that are sent on RTR (252/253, RTR allowed)."""
        values = self.store.values
        return {pdo.cob_id for pdo in self.tpdos.values()
                if pdo.valid and pdo.trans_type in (RTR_SAMPLED, RTR_NOW)
                and not values[key(pdo.comm, 1)] & COB_NO_RTR}

    def on_remote_request(self, cob_id: int) -> None:
        """An RTR on ``cob_id`` (lock held): the RTR-only TPDOs on it answer."""
        if not self.tpdo_allowed():
            return
        for pdo in self.tpdos.values():
            if not pdo.valid or pdo.cob_id != cob_id or cob_id not in self.remote_cob_ids():
                continue
            if pdo.trans_type == RTR_NOW:
                self.emit(pdo, self.packed(pdo), time.monotonic())
            elif pdo.trans_type == RTR_SAMPLED and pdo.number in self.sampled:
                self.emit(pdo, self.sampled.pop(pdo.number), time.monotonic())

    def leave_operational(self) -> None:
        super().leave_operational()
        self.sampled.clear()
