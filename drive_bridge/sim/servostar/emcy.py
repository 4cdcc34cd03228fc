"""The SERVOSTAR's EMCY frames [2.10, 3.1-3.4]: byte 3 is the error category, bytes 4..7 are
zero; every error EMCY is followed by a second EMCY with code 0x0000 carrying the error register
as it is now; an error reset sends 0x0000 with the remaining register (0 once none is left),
also when only some errors went. 0x1003 keeps the last error only (its size comes from the EDS).

Where the manual leaves room (its German original, §3.4.4 and the printed examples of §6.1.10
and §6.2.1.1), two options:

- ``emcy_error_register`` 'class' (default): an error sets only the error register bit of its
  code's CiA 301 class (2xxx current, 3xxx voltage, 4xxx temperature, 81xx / 82xx communication,
  86xx-89xx device profile, 10xx generic), a code of no such class bit 7 (manufacturer
  specific); no generic bit 0 beside a class bit. Both printed examples of a motor temperature
  fault (4310h) show error register 08h, not the 09h of CiA 301's generic bit; §6.1.10's
  follow-up 88h is read as that fault together with the resolver's own (the resolver plug also
  carries the motor temperature sensor: 7303h, bit 7). 'cia301': the generic bit 0 with every
  class bit.
- ``emcy_follow_up_category`` false (default): byte 3 of the follow-up frame is 00h, as the one
  printed follow-up with a category column shows (§6.2.1.1: ``081: 00 00 08 00 00 00 00 00``
  after ``081: 10 43 08 01 ...``) and as the error state machine's "manufacturer field zero"
  of the reset frames says (§3.4.4.1 transition 2); true: byte 3 repeats the category, as the
  sentence of §3.4.4.2 ("Byte 3 enthält die Kategorie") reads.
"""
from __future__ import annotations

from drive_bridge.sim.emcy import (
    REG_COMMUNICATION,
    REG_CURRENT,
    REG_DEVICE_PROFILE,
    REG_GENERIC,
    REG_MANUFACTURER,
    REG_TEMPERATURE,
    REG_VOLTAGE,
    EmcyProducer,
    register_bits,
)
from drive_bridge.sim.servostar.objects import CATEGORIES

REGISTER_READINGS = ('class', 'cia301')


def category_of(code: int, source: str = 'device') -> int:
    """The EMCY table's category of ``code``; unknown codes: 3 for PDO processing errors, else 1."""
    return CATEGORIES.get(code, 3 if source == 'pdo' else 1)


def class_bit(code: int) -> int:
    """The one error register bit of ``code`` (reading 'class', module docstring)."""
    group, high = code >> 12, code >> 8
    if group == 0x1:
        return REG_GENERIC
    if group == 0x2:
        return REG_CURRENT
    if group == 0x3:
        return REG_VOLTAGE
    if group == 0x4:
        return REG_TEMPERATURE
    if high in (0x81, 0x82):
        return REG_COMMUNICATION
    if 0x86 <= high <= 0x89:
        return REG_DEVICE_PROFILE
    return REG_MANUFACTURER


class ServostarEmcy(EmcyProducer):
    """EMCY with the category byte and the follow-up frame (module docstring)."""

    register_reading = 'class'  # the option emcy_error_register
    follow_up_category = False  # the option emcy_follow_up_category

    def register_bits(self, code: int) -> int:
        return class_bit(code) if self.register_reading == 'class' else register_bits(code)

    def error(self, code: int, source: str = 'device', manufacturer: bytes = b'',
              transient: bool = False, emit: bool = True) -> None:
        category = manufacturer[:1] or bytes([category_of(code, source)])
        super().error(code, source, category, transient, emit)
        if emit:  # the error state after every EMCY
            self.emit(0x0000, self.register, category if self.follow_up_category else b'')

    def clear(self, source: str | None = None, keep: frozenset[int] = frozenset()) -> None:
        """Forget the errors of ``source`` (all if None) but the codes in ``keep``; EMCY 0x0000
        with the remaining error register if any went."""
        before = len(self.active_errors)
        self.active_errors = {k: v for k, v in self.active_errors.items()
                        if (source is not None and k[0] != source) or k[1] in keep}
        if len(self.active_errors) != before:
            self.emit(0x0000, self.register, b'')

    def codes(self, source: str) -> list[int]:
        return [code for (s, code) in self.active_errors if s == source]
