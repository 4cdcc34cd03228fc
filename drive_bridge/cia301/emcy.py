"""EMCY decoding: code and error register to text, and the event the core reports."""
from __future__ import annotations

import struct
from collections.abc import Mapping
from dataclasses import dataclass, replace
from enum import Enum

from drive_bridge.cia301.emcy_codes import ERROR_REGISTER_BITS, GENERIC_EMCY

EMCY_FORMAT = struct.Struct('<HB5s')


def describe_code(code: int, family_texts: Mapping[int, str] | None = None) -> str:
    """Text of an EMCY error code: the drive family's table first, then CiA 301/402,
    then the code's class (0xABCD -> 0xAB00 -> 0xA000)."""
    tables = (family_texts or {}, GENERIC_EMCY)
    for table in tables:
        if code in table:
            return table[code]
    for mask in (0xFFF0, 0xFF00, 0xF000):
        for table in tables:
            if code & mask in table:
                return f'{table[code & mask]} (code 0x{code:04X})'
    return f'unknown error code 0x{code:04X}'


def describe_register(register: int) -> str:
    """Set bits of the error register 0x1001, comma separated ('' when none)."""
    return ', '.join(name for bit, name in ERROR_REGISTER_BITS if register & (1 << bit))


class Severity(str, Enum):
    """How bad an EMCY is, as the drive family reads it."""

    INFO = 'info'  # an error reset / no-error report
    WARNING = 'warning'  # the drive keeps running
    ERROR = 'error'  # a fault


@dataclass(frozen=True)
class EmcyEvent:
    """One EMCY frame from a node, decoded."""

    node_id: int
    node_name: str
    code: int
    register: int
    manufacturer: bytes
    timestamp: float
    text: str
    register_text: str
    slot: int | None = None  # axis slot on the node when the family can tell, else None
    severity: Severity = Severity.ERROR
    reset: bool | None = None  # the family's word; None: CiA 301's (code 0x00xx)

    @property
    def is_reset(self) -> bool:
        """An 'error reset / no error' EMCY: the node reports its errors cleared."""
        return self.code & 0xFF00 == 0 if self.reset is None else self.reset

    def with_meaning(self, **changes: object) -> EmcyEvent:
        """A copy with a family's reading (text, slot, severity, reset) applied."""
        return replace(self, **changes)  # type: ignore[arg-type]

    def __str__(self) -> str:
        register = f', register 0x{self.register:02X} ({self.register_text})' if self.register else ''
        return f'EMCY node {self.node_id} ({self.node_name}): 0x{self.code:04X} {self.text}{register}'


def decode_emcy(node_id: int, node_name: str, data: bytes, timestamp: float,
                family_texts: Mapping[int, str] | None = None) -> EmcyEvent:
    """Decode an EMCY payload. Short frames (seen from real devices, DLC 0..7) are padded
    with zeros rather than dropped, so the event is still reported."""
    code, register, manufacturer = EMCY_FORMAT.unpack(bytes(data[:8]).ljust(8, b'\0'))
    return EmcyEvent(node_id, node_name, code, register, manufacturer, timestamp,
                     describe_code(code, family_texts), describe_register(register),
                     severity=Severity.INFO if code & 0xFF00 == 0 else Severity.ERROR)
