"""SINAMICS messages (faults F, alarms A) and how they show on CANopen [2.6, 2.7, 6]:

- EMCY: code 0x1000 for a drive fault, 0x8110 A08751, 0x8120 A08752, 0x8130 F08700 with value
  2, 0x1001 every other message F08700..F08799; byte 2 the error register; bytes 3-4 the
  SINAMICS number (little-endian, as all CANopen data [B]); byte 5 the drive object; bytes 6-7
  reserved (0). Faults always send one; alarms only in the CAN range 8700..8799, the others
  show only as the statusword warning bit. 0x0000 once every fault is acknowledged and every
  CAN alarm gone.
- 0x1001: bit 0 on every message that is signalled (faults, CAN alarms), bit 4 for the CAN
  range, bit 7 for every other.
- 0x1003 (p8611): one block per module (the drive object in axis slot k: count at 2 + 9k, up
  to 8 entries after it), the Control Unit's block at 0x4A / 0x4B..0x52, sub 1 the number of
  modules, sub 0 the number of entries in all blocks. An entry is (SINAMICS number << 16) |
  EMCY code [B: the manual does not give the entry layout]; the entries of a block are in
  chronological order of occurrence, the oldest first.
"""
from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from drive_bridge.sim.emcy import EmcyProducer
from drive_bridge.sim.s120.objects import (
    A08751,
    A08752,
    CAN_RANGE,
    COMMUNICATION_ERROR_VALUE,
    CU,
    EMCY_CAN_OTHER,
    EMCY_DRIVE_FAULT,
    EMCY_ERROR_PASSIVE,
    EMCY_LIFE_GUARD,
    EMCY_TELEGRAM_LOST,
    ERROR_HISTORY,
    F08700,
    REG_COMMUNICATION,
    REG_GENERIC,
    REG_MANUFACTURER,
)
from drive_bridge.sim.store import ObjectStore, key

BLOCK = 9  # count + 8 entries per module
CU_BLOCK = 0x4A
MODULES = 8


@dataclass
class Message:
    """One active SINAMICS fault or alarm of a drive object."""

    number: int
    do: int
    fault: bool
    value: int = 0  # fault value (r0949)
    persistent: bool = False  # the cause is still there (a fault cannot be acknowledged, an alarm stays)
    reaction: str = 'OFF2'

    @property
    def label(self) -> str:
        return f'{"F" if self.fault else "A"}{self.number:05d}'

    @property
    def can(self) -> bool:
        return self.number in CAN_RANGE

    @property
    def signalled(self) -> bool:
        """Sent as EMCY and listed in 0x1001 / 0x1003: every fault, and alarms of the CAN range."""
        return self.fault or self.can

    @property
    def code(self) -> int:
        if self.number == A08751:
            return EMCY_TELEGRAM_LOST
        if self.number == A08752:
            return EMCY_ERROR_PASSIVE
        if self.number == F08700 and self.value == COMMUNICATION_ERROR_VALUE:
            return EMCY_LIFE_GUARD
        return EMCY_CAN_OTHER if self.can else EMCY_DRIVE_FAULT

    @property
    def register_bits(self) -> int:
        return REG_GENERIC | (REG_COMMUNICATION if self.can else REG_MANUFACTURER)

    @property
    def entry(self) -> int:
        """The 0x1003 entry."""
        return (self.number & 0xFFFF) << 16 | self.code

    @property
    def manufacturer(self) -> bytes:
        """EMCY bytes 3..7: number, drive object, two reserved bytes."""
        return struct.pack('<HBxx', self.number & 0xFFFF, self.do & 0xFF)


class S120Emcy(EmcyProducer):
    """EMCY frames of the SINAMICS messages; the generic CiA 301 errors of the slave (PDO length)
    keep their own codes. The axis' CiA 402 faults are not signalled here: the drive sends the
    message that caused them."""

    def __init__(self, store: ObjectStore, send: Callable[[int, bytes], None]) -> None:
        super().__init__(store, send)
        self.messages: Callable[[], Sequence[Message]] = lambda: ()

    @property
    def register(self) -> int:
        bits = super().register
        for message in self.messages():
            if message.signalled:
                bits |= message.register_bits
        return bits

    def error(self, code: int, source: str = 'device', manufacturer: bytes = b'',
              transient: bool = False, emit: bool = True) -> None:
        if source.startswith('axis'):
            return
        super().error(code, source, manufacturer, transient, emit)

    def clear(self, source: str | None = None) -> None:
        if source is not None and source.startswith('axis'):
            return
        before = bool(self.active_errors)
        self.active_errors = {k: v for k, v in self.active_errors.items() if source is not None and k[0] != source}
        if before and not self.active_errors and not self.register:
            self.all_clear()

    def push_history(self, code: int) -> None:
        """0x1003 is built from the messages, per module (:func:`write_history`)."""

    def signal(self, message: Message) -> None:
        self.emit(message.code, self.register, message.manufacturer)

    def all_clear(self) -> None:
        self.emit(0x0000, 0, b'')


def write_history(store: ObjectStore, messages: Sequence[Message], modules: Sequence[int]) -> None:
    """0x1003 from the signalled messages; ``modules``: the drive object of each axis slot."""
    values = store.values

    def put(sub: int, value: int) -> None:
        k = key(ERROR_HISTORY, sub)
        if k in store:
            values[k] = value

    total = 0
    blocks = [(2 + BLOCK * m, modules[m] if m < len(modules) else None) for m in range(MODULES)]
    for start, do in [*blocks, (CU_BLOCK, CU)]:
        entries = [m.entry for m in messages if m.signalled and do is not None and m.do == do][:8]
        put(start, len(entries))
        for i in range(8):
            put(start + 1 + i, entries[i] if i < len(entries) else 0)
        total += len(entries)
    put(1, len(modules))
    put(0, total)
