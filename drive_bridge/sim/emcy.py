"""EMCY producer with the error register (0x1001) and the error history (0x1003).

Kept apart from the slave so the bookkeeping CiA 301 asks for (register bits from
the error class, newest history entry at sub 1, error reset 0x0000 only once every
error is gone) is in one small place.
"""
from __future__ import annotations

import struct
from collections.abc import Callable

from drive_bridge.sim.store import ObjectStore, key

ERROR_REGISTER = 0x1001
ERROR_HISTORY = 0x1003
COB_ID_EMCY = 0x1014
COB_ID_INVALID = 1 << 31

# error register (0x1001) bits
REG_GENERIC = 1 << 0
REG_CURRENT = 1 << 1
REG_VOLTAGE = 1 << 2
REG_TEMPERATURE = 1 << 3
REG_COMMUNICATION = 1 << 4
REG_DEVICE_PROFILE = 1 << 5
REG_MANUFACTURER = 1 << 7

_EMCY = struct.Struct('<HB5s')


def register_bits(code: int) -> int:
    """Error register bits for an EMCY error code (CiA 301 table 21 classes)."""
    bits = REG_GENERIC
    high = code >> 12
    if high == 0x2:
        bits |= REG_CURRENT
    elif high == 0x3:
        bits |= REG_VOLTAGE
    elif high == 0x4:
        bits |= REG_TEMPERATURE
    elif code >> 8 in (0x81, 0x82):
        bits |= REG_COMMUNICATION
    elif code >> 8 in (0x86, 0x87, 0x88, 0x89):  # CiA 402 control / positioning errors
        bits |= REG_DEVICE_PROFILE
    elif code >> 8 == 0xFF:
        bits |= REG_MANUFACTURER
    return bits


def emcy_payload(code: int, register: int, manufacturer: bytes = b'') -> bytes:
    """The 8 data bytes: code (LE16), error register, 5 manufacturer bytes (zero padded)."""
    return _EMCY.pack(code & 0xFFFF, register & 0xFF, bytes(manufacturer[:5]).ljust(5, b'\0'))


class EmcyProducer:
    """Active errors per source, error register, history and the EMCY frames.

    A vendor simulator's producer extends it through ``store``, ``active_errors`` (the active
    errors: (source, code) -> register bits), :meth:`push_history` (a hook: how an error enters
    0x1003) and :meth:`emit` (one EMCY frame); the rest is private.
    """

    def __init__(self, store: ObjectStore, send: Callable[[int, bytes], None]) -> None:
        self.store = store
        self._send = send
        self.active_errors: dict[tuple[str, int], int] = {}  # (source, code) -> register bits
        subs = sorted(s for k in store.keys_between(ERROR_HISTORY, ERROR_HISTORY)
                      if (s := k & 0xFF) > 0)
        self.history_size = len(subs)
        self.sent: list[tuple[int, int, bytes]] = []  # (code, register, manufacturer) for inspection, bounded

    @property
    def register(self) -> int:
        bits = 0
        for value in self.active_errors.values():
            bits |= value
        return bits

    @property
    def active_codes(self) -> list[int]:
        return [code for (_source, code) in self.active_errors]

    def is_active(self, source: str | None = None) -> bool:
        return any(source is None or s == source for (s, _c) in self.active_errors)

    def error(self, code: int, source: str = 'device', manufacturer: bytes = b'',
              transient: bool = False, emit: bool = True) -> None:
        """Record an error (unless ``transient``), add it to the history and send its EMCY.

        ``emit=False`` only records it as active: a consequence of an error already
        signalled (e.g. each axis' fault after one heartbeat-loss EMCY).
        """
        if not transient:
            self.active_errors[(source, code)] = self.register_bits(code)
        if not emit:
            return
        self.push_history(code)
        self.emit(code, self.register | (0 if not transient else self.register_bits(code)), manufacturer)

    def register_bits(self, code: int) -> int:
        """Hook: the error register bits an error ``code`` sets (default: CiA 301's, generic bit
        and class bit)."""
        return register_bits(code)

    def clear(self, source: str | None = None) -> None:
        """Forget the errors of ``source`` (all if None); EMCY 0x0000 once none is left."""
        before = len(self.active_errors)
        self.active_errors = {k: v for k, v in self.active_errors.items() if source is not None and k[0] != source}
        if before and not self.active_errors:
            self.emit(0x0000, 0, b'')

    def reset(self) -> None:
        """Power-on / reset: no active errors, no frame."""
        self.active_errors.clear()

    def clear_history(self) -> None:
        for sub in range(1, self.history_size + 1):
            self.store.values[key(ERROR_HISTORY, sub)] = 0
        self.store.values[key(ERROR_HISTORY, 0)] = 0

    def push_history(self, code: int) -> None:
        """Hook: add ``code`` to the error history 0x1003 (newest at sub 1)."""
        if not self.history_size:
            return
        values = self.store.values
        for sub in range(self.history_size, 1, -1):
            values[key(ERROR_HISTORY, sub)] = values[key(ERROR_HISTORY, sub - 1)]
        values[key(ERROR_HISTORY, 1)] = code & 0xFFFF
        values[key(ERROR_HISTORY, 0)] = min(self.history_size, values[key(ERROR_HISTORY, 0)] + 1)

    def emit(self, code: int, register: int, manufacturer: bytes) -> None:
        """Send one EMCY frame (unless 0x1014 marks the COB-ID invalid); kept in ``sent``."""
        cob = self.store.values.get(key(COB_ID_EMCY, 0), 0)
        if len(self.sent) < 1000:
            self.sent.append((code, register, bytes(manufacturer[:5])))
        if cob & COB_ID_INVALID:
            return
        self._send(cob & 0x7FF, emcy_payload(code, register, manufacturer))
