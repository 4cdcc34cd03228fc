"""The S120's PDO rules on top of CiA 301's [2.4, 2.5]:

- 8 RPDOs and 8 TPDOs per drive object (the EDS's 0x14xx.. + 0x40 per object), at most 4
  entries each (the EDS's sub-indices);
- at most 25 valid RPDOs over all drive objects (a hardware limit): while more are valid, alarm
  A08758 is raised (:attr:`S120PdoEngine.on_limit`) and only the first 25 that became valid are
  received;
- mapping sub 0 read-only (``sub0_read_only``, the manual's Tab. 2-3/2-4; the real EDS says
  rw and is the default): sub 0 writes abort 0x06010002, entries may be written whenever the
  PDO is invalid (COB-ID bit 31), and sub 0 follows as the number of leading non-zero entries;
- every received RPDO is reported with its frame time stamp (:attr:`S120PdoEngine.on_received`)
  for the telegram monitoring of p8848 (A08751);
- a synchronous RPDO takes effect at the SYNC after the one it followed (the generic engine's
  latch: all types 0..240 alike).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.pdo import MAX_BITS, Pdo, PdoEngine
from drive_bridge.sim.s120.objects import ABORT_PDO_TOO_LONG, ABORT_READ_ONLY, ABORT_STATE, MAX_VALID_RPDOS
from drive_bridge.sim.store import key


class S120PdoEngine(PdoEngine):
    """The S120's PDO rules (module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.sub0_read_only = False
        self.on_limit: Callable[[bool], None] = lambda exceeded: None
        self.on_received: Callable[[Pdo, float], None] = lambda pdo, stamp: None
        self.limit_exceeded = False
        self.valid_rpdos = 0
        self._order: list[int] = []  # RPDO numbers in the order they became valid

    # -- the 25 RPDO limit ------------------------------------------------------------------------
    def rebuild(self) -> None:
        """After a reset or a restore: the validity order starts again in number order."""
        was, self.limit_exceeded = self.limit_exceeded, False
        self._order = []
        super().rebuild()
        if was and not self.limit_exceeded:
            self.on_limit(False)

    def accepted_rpdos(self, valid: list[Pdo]) -> list[Pdo]:
        numbers = {p.number for p in valid}
        self._order = [n for n in self._order if n in numbers]
        self._order += [p.number for p in valid if p.number not in self._order]
        self.valid_rpdos = len(self._order)
        exceeded = self.valid_rpdos > MAX_VALID_RPDOS
        if exceeded != self.limit_exceeded:
            self.limit_exceeded = exceeded
            self.on_limit(exceeded)
        served = set(self._order[:MAX_VALID_RPDOS])
        return [p for p in valid if p.number in served]

    # -- mapping sub 0 read-only --------------------------------------------------------------------
    def validate(self, index: int, subindex: int, value: int) -> None:
        pdo = self._by_index[index]
        if not self.sub0_read_only or index != pdo.mapping:
            super().validate(index, subindex, value)
            return
        if subindex == 0:
            raise SdoAbortedError(ABORT_READ_ONLY)
        values = self._store.values
        if self.mapping_locked(pdo, values[key(pdo.comm, 1)]):
            raise SdoAbortedError(ABORT_STATE)
        if value != 0:
            self._check_entry(pdo, value)
        entries = self._entries(pdo, {subindex: value})
        if sum(e & 0xFF for e in entries) > MAX_BITS:
            raise SdoAbortedError(ABORT_PDO_TOO_LONG)

    def written(self, index: int) -> None:
        pdo = self._by_index[index]
        if self.sub0_read_only and index == pdo.mapping:
            self._store.values[key(pdo.mapping, 0)] = len(self._entries(pdo, {}))
        super().written(index)

    def _entries(self, pdo: Pdo, changed: dict[int, int]) -> list[int]:
        """The leading non-zero mapping entries (with ``changed`` sub-indices replaced)."""
        entries = []
        sub = 1
        while key(pdo.mapping, sub) in self._store:
            entry = changed.get(sub, self._store.values[key(pdo.mapping, sub)])
            if not entry:
                break
            entries.append(entry)
            sub += 1
        return entries

    # -- telegram monitoring --------------------------------------------------------------------------
    def on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self._lock:
            pdo = self._rx_by_cob.get(can_id)
            if pdo is not None and self._rpdo_allowed() and len(data) >= pdo.struct.size:
                self.on_received(pdo, timestamp)
            super().on_rpdo(can_id, data, timestamp)
