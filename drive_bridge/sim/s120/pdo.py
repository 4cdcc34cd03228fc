"""The S120's PDO rules on top of CiA 301's [2.4, 2.5]:

- 8 RPDOs and 8 TPDOs per drive object (the EDS's 0x14xx.. + 0x40 per object), at most 4
  entries each (the EDS's sub-indices);
- at most 25 valid RPDOs over all drive objects (a hardware limit): while more are valid, alarm
  A08758 is raised (:attr:`S120PdoEngine.on_limit`) and only the first 25 that became valid are
  received;
- mapping entries may be written whenever the PDO is invalid (COB-ID bit 31), whatever sub 0
  holds: the manual's online procedure (COB-ID invalid, the entries, COB-ID valid; §4.3.1);
  sub 0 then follows as the number of leading non-zero entries. Sub 0 itself is read-write
  (the real EDS, the default: CiA 301's sub 0 = 0, entries, sub 0 = n works too, sub 0 staying
  0 until the master writes n) or read-only (``sub0_read_only``, the manual's Tab. 2-3/2-4:
  abort 0x06010002). A mapping longer than 64 bits is refused when the PDO is made valid
  (0x06040042), not while its entries are being written;
- every received RPDO is reported with its frame time stamp (:attr:`S120PdoEngine.on_received`)
  for the telegram monitoring of p8848 (A08751);
- a synchronous RPDO takes effect at the SYNC after the one it followed (the generic engine's
  latch: all types 0..240 alike).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.pdo import PdoEngine
from drive_bridge.sim.pdocodec import COB_INVALID, Pdo
from drive_bridge.sim.pdoparams import MAX_BITS
from drive_bridge.sim.s120.objects import ABORT_PDO_TOO_LONG, ABORT_READ_ONLY, ABORT_STATE, MAX_VALID_RPDOS
from drive_bridge.sim.store import key


class S120PdoEngine(PdoEngine):
    """The S120's PDO rules (module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.sub0_read_only = False
        self._follow: int | None = None  # the mapping whose sub 0 follows the entry being written
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

    # -- mapping: the manual's online procedure [2.5] ----------------------------------------------
    def validate(self, index: int, subindex: int, value: int) -> None:
        """Mapping entries are written whenever the PDO is invalid, whatever sub 0 holds (the
        manual's online procedure: COB-ID invalid, the entries, COB-ID valid); sub 0 is
        read-write (the CiA 301 procedure, the EDS) or read-only (``sub0_read_only``). The
        length of the mapping is checked when the PDO is made valid."""
        self._follow = None
        pdo = self.by_index[index]
        values = self.store.values
        if index == pdo.comm:
            cob = values[key(pdo.comm, 1)]
            if subindex == 1 and cob & COB_INVALID and not value & COB_INVALID:
                bits = sum(e & 0xFF for e in self._mapped(pdo))
                if bits > MAX_BITS:
                    raise SdoAbortedError(ABORT_PDO_TOO_LONG)
            super().validate(index, subindex, value)
            return
        if subindex == 0:
            if self.sub0_read_only:
                raise SdoAbortedError(ABORT_READ_ONLY)
            super().validate(index, subindex, value)
            return
        if self.mapping_locked(pdo, values[key(pdo.comm, 1)]):
            raise SdoAbortedError(ABORT_STATE)
        if value != 0:
            self.check_entry(pdo, value)
        # sub 0 follows the entries unless a CiA 301 master set it to 0 to write them
        self._follow = index if self.sub0_read_only or values[key(index, 0)] != 0 else None

    def written(self, index: int) -> None:
        pdo = self.by_index[index]
        if index == pdo.mapping and self._follow == index:
            self.store.values[key(pdo.mapping, 0)] = len(self._entries(pdo))
        self._follow = None
        super().written(index)

    def _mapped(self, pdo: Pdo) -> list[int]:
        """The entries sub 0 counts."""
        values = self.store.values
        return [values[key(pdo.mapping, sub)] for sub in range(1, values[key(pdo.mapping, 0)] + 1)]

    def _entries(self, pdo: Pdo) -> list[int]:
        """The leading non-zero mapping entries."""
        entries = []
        sub = 1
        while key(pdo.mapping, sub) in self.store:
            entry = self.store.values[key(pdo.mapping, sub)]
            if not entry:
                break
            entries.append(entry)
            sub += 1
        return entries

    # -- telegram monitoring --------------------------------------------------------------------------
    def on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self.lock:
            pdo = self.rx_by_cob.get(can_id)
            if pdo is not None and self.rpdo_allowed() and len(data) >= pdo.struct.size:
                self.on_received(pdo, timestamp)
            super().on_rpdo(can_id, data, timestamp)
