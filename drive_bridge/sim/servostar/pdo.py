"""The SERVOSTAR's PDOs [2.5-2.8]: four channels per direction whose content is chosen by number
from the PDO library (0x2600-0x2603 / 0x2A00-0x2A03); package docstring for the rules."""
from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.pdo import PdoEngine
from drive_bridge.sim.pdocodec import Pdo
from drive_bridge.sim.pdoparams import ABORT_INCOMPATIBLE, ABORT_PDO_TOO_LONG, MAX_BITS
from drive_bridge.sim.servostar.objects import (
    ABORT_INVALID_VALUE,
    ABORT_READ_ONLY,
    ASCII_PDO,
    CHANGE_MASKS,
    FREE_PDOS,
    MDRV,
    MOTION_TASK,
    ONLY_ASYNC,
    RPDO_LIBRARY,
    RPDO_ONLY_ASYNC,
    RPDO_ONLY_SYNC,
    RPDO_SELECT,
    TPDO_LIBRARY,
    TPDO_ONLY_ASYNC,
    TPDO_ONLY_SYNC,
    TPDO_SELECT,
    TRAJECTORY_PDO,
    VALUE,
)
from drive_bridge.sim.store import key

MAX_ENTRIES = 8
TRAJECTORY_SETPOINT = key(MOTION_TASK, 4)


class ServostarPdoEngine(PdoEngine):
    """Library PDOs, free PDOs 37-40, per-PDO transmission types, change masks, RPDO 33 halves,
    the ASCII PDO 21 (package docstring)."""

    change_masks = CHANGE_MASKS

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._selected: dict[tuple[bool, int], int] = {}
        self._mapping_write: tuple[int, int, int] | None = None
        # set by the drive: the byte offset of this drive's half of RPDO 33, the ASCII terminal
        self.trajectory_offset: Callable[[], int] = lambda: 0
        self.ascii_received: Callable[[bytes], None] = lambda data: None
        self.applying: int | None = None  # the library number of the RPDO being applied now

    # -- selection -------------------------------------------------------------------------------------
    def selection(self, pdo: Pdo) -> int:
        """The library number selected in ``pdo``'s channel (0: none)."""
        return self.store.values.get(key((TPDO_SELECT if pdo.transmit else RPDO_SELECT) + pdo.number - 1), 0)

    def channel(self, transmit: bool, number: int) -> Pdo:
        return (self.tpdos if transmit else self.rpdos)[number]

    @staticmethod
    def check_select(transmit: bool, number: int) -> None:
        """A library number the channel cannot take (reserved numbers): 0x06090030."""
        if number not in (TPDO_LIBRARY if transmit else RPDO_LIBRARY) and number not in FREE_PDOS:
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    def select(self, transmit: bool, number: int, value: int) -> None:
        """Channel ``number`` now carries library PDO ``value``: its mapping object shows the
        library's mapping (a free PDO starts empty, unless it was selected there already) and a
        transmission type the PDO cannot run with is replaced (255 for the asynchronous-only
        PDOs, 1 for the SYNC-only ones)."""
        pdo = self.channel(transmit, number)
        previous = self._selected.get((transmit, number))
        self._selected[(transmit, number)] = value
        values = self.store.values
        if value in FREE_PDOS:
            if previous != value:
                self._set_mapping(pdo, ())
        else:
            self._set_mapping(pdo, (TPDO_LIBRARY if transmit else RPDO_LIBRARY)[value])
        trans = values[key(pdo.comm, 2)]
        only_async = TPDO_ONLY_ASYNC if transmit else RPDO_ONLY_ASYNC
        only_sync = TPDO_ONLY_SYNC if transmit else RPDO_ONLY_SYNC
        if value in only_async:
            values[key(pdo.comm, 2)] = ONLY_ASYNC
        elif value in only_sync and not 1 <= trans <= 240:
            values[key(pdo.comm, 2)] = 1
        self._mapping_write = None
        self.written(pdo.mapping)

    def _set_mapping(self, pdo: Pdo, entries: tuple[int, ...]) -> None:
        values = self.store.values
        for sub in range(1, MAX_ENTRIES + 1):
            if key(pdo.mapping, sub) in values:
                values[key(pdo.mapping, sub)] = entries[sub - 1] if sub <= len(entries) else 0
        values[key(pdo.mapping, 0)] = len(entries)

    def rebuild(self) -> None:
        self._selected = {(pdo.transmit, pdo.number): self.selection(pdo)
                          for pdo in (*self.rpdos.values(), *self.tpdos.values())}
        super().rebuild()

    # -- parameter writes -------------------------------------------------------------------------------
    def validate(self, index: int, subindex: int, value: int) -> None:
        pdo = self.by_index[index]
        number = self.selection(pdo)
        if index == pdo.mapping:
            if number not in FREE_PDOS:
                raise SdoAbortedError(ABORT_READ_ONLY)  # a library PDO's mapping is read-only
            self._check_free_mapping(pdo, subindex, value)
            self._mapping_write = (index, subindex, value)
            return
        if subindex == 2:
            self._check_transmission_type(pdo, number, value)
        super().validate(index, subindex, value)

    def mapping_locked(self, pdo: Pdo, cob: int) -> bool:
        return False  # the manual's examples map and change COB-IDs of valid PDOs directly

    def _check_transmission_type(self, pdo: Pdo, number: int, value: int) -> None:
        only_async = TPDO_ONLY_ASYNC if pdo.transmit else RPDO_ONLY_ASYNC
        only_sync = TPDO_ONLY_SYNC if pdo.transmit else RPDO_ONLY_SYNC
        if number in only_async and value != ONLY_ASYNC:
            raise SdoAbortedError(ABORT_INVALID_VALUE)
        if number in only_sync and not 1 <= value <= 240:
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    def _check_free_mapping(self, pdo: Pdo, subindex: int, value: int) -> None:
        values = self.store.values
        count = values[key(pdo.mapping, 0)]
        if subindex == 0:
            if value > MAX_ENTRIES:
                raise SdoAbortedError(ABORT_INVALID_VALUE)
            bits = 0
            for sub in range(1, value + 1):
                entry = values[key(pdo.mapping, sub)]
                if entry == 0:
                    raise SdoAbortedError(ABORT_INCOMPATIBLE)
                self.check_entry(pdo, entry)
                bits += entry & 0xFF
            if bits > MAX_BITS:
                raise SdoAbortedError(ABORT_PDO_TOO_LONG)
            return
        if value == 0:
            return
        if subindex > count + 1:
            raise SdoAbortedError(ABORT_INCOMPATIBLE)  # entries are appended one after the other
        self.check_entry(pdo, value)
        bits = sum(values[key(pdo.mapping, s)] & 0xFF for s in range(1, count + 1) if s != subindex)
        if bits + (value & 0xFF) > MAX_BITS:
            raise SdoAbortedError(ABORT_PDO_TOO_LONG)

    def written(self, index: int) -> None:
        """The drive keeps sub 0 of a free PDO's mapping itself: writing 0 deletes the PDO's data,
        every entry written counts (the manual never writes the count back)."""
        write, self._mapping_write = self._mapping_write, None
        pdo = self.by_index[index]
        if write is not None and write[0] == pdo.mapping:
            values = self.store.values
            _, subindex, value = write
            if subindex == 0 and value == 0:
                self._set_mapping(pdo, ())
            elif subindex > 0:
                count = 0
                while count < MAX_ENTRIES and values.get(key(pdo.mapping, count + 1), 0):
                    count += 1
                values[key(pdo.mapping, 0)] = count
        super().written(index)

    # -- receive ------------------------------------------------------------------------------------------
    def accepted_rpdos(self, valid: list[Pdo]) -> list[Pdo]:
        if self.store.values.get(key(MDRV, VALUE), 0):
            return [pdo for pdo in valid if pdo.number <= 3]  # multidrive mode: three channels [1.3]
        return valid

    def on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self.lock:
            pdo = self.rx_by_cob.get(can_id)
            if pdo is None or not self.rpdo_allowed():
                return
            number = self.selection(pdo)
            if number == ASCII_PDO:
                self.rpdo_received += 1
                self.ascii_received(bytes(data))
                return
            if number in RPDO_ONLY_SYNC and not pdo.synchronous:
                return  # RPDO 33 is not processed asynchronously
            self.applying = number
            try:
                super().on_rpdo(can_id, data, timestamp)
            finally:
                self.applying = None

    def apply_latched(self) -> None:
        """At SYNC: RPDO 33 gives this drive one setpoint, its half of the frame (0x2721)."""
        for pdo in self.rx_by_cob.values():
            if pdo.latched is not None and self.selection(pdo) == TRAJECTORY_PDO:
                data, pdo.latched = pdo.latched, None
                offset = self.trajectory_offset()
                value = int.from_bytes(data[offset:offset + 4].ljust(4, b'\0'), 'little', signed=True)
                self.applying = TRAJECTORY_PDO
                try:
                    self.write_many([(TRAJECTORY_SETPOINT, value)])
                finally:
                    self.applying = None
        super().apply_latched()

    # -- transmit -----------------------------------------------------------------------------------------
    def send_ascii(self, text: bytes) -> int:
        """The ASCII terminal's output on every valid TPDO channel carrying PDO 21, 8 characters a
        frame, the last one padded with NUL; the number of frames sent."""
        if not text or not self.tpdo_allowed():
            return 0
        sent = 0
        for pdo in self.tpdos.values():
            if pdo.valid and self.selection(pdo) == ASCII_PDO:
                for start in range(0, len(text), 8):
                    chunk = text[start:start + 8].ljust(8, b'\0')
                    pdo.last_data, pdo.last_time = chunk, time.monotonic()
                    self.send(pdo.cob_id, chunk)
                    self.tpdo_sent += 1
                    sent += 1
        return sent
