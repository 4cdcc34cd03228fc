"""The OPEN drive's parameters (P, 0x200D) and connections (C, 0x200E) the simulator
knows, with their format words (0x2001 / 0x2002 / 0x2026 layout, opendrive.md §3.2).

Format word (word 1 of a format record), rebuilt from the appendix's worked examples
(§6.6-§6.10: 0x1131 = Free, percent of base, 3.1 digits; 0x2231 = Reserved, proportional,
3.1; 0x2020 = Reserved connection, direct, 2.0):

====== ======= ============================================================================
bits   nibble  meaning
====== ======= ============================================================================
15-12  3       class: 0 not managed (unused slot), 1 Free (on-line), 2 Reserved (off-line
               and key P60), 4 TDE (off-line and key P99)
11-8   2       representation: 0 direct (signed), 1 percent of base (real % = v * 100 /
               base), 2 proportional to base (real = v / base), 3 direct unsigned
7-4    1       integer digits on the display
3-0    0       decimal digits on the display
====== ======= ============================================================================

Words 2 and 3 are the minimum and maximum in internal units (as the representation reads
them: unsigned for representation 3, else signed), word 4 the base (1 for connections),
word 5 (0x2026 only) the default. Element k of 0x200D / 0x200E holds Pk / Ck; its format
is at words 4k..4k+3 of 0x2001 / 0x2002 (5k..5k+4 of 0x2026).

Which parameter is which (n_MAX, T_nom, pole pairs, f_pwm, ...) is not in the appendix:
besides the ones it names (P54-P56, P60, P99, P162, P163, C1-C8, C14-C16, C48, C52, C63)
the table holds a few ordinary parameters with the example formats, so that every class
and representation is present. The drive's constants are simulator options instead.
This module is plain data: the simulator reads it, and edsgen takes the EDS defaults from it.
"""
from __future__ import annotations

from dataclasses import dataclass

FREE, RESERVED, TDE = 1, 2, 4
DIRECT, PERCENT, PROPORTIONAL, UNSIGNED = 0, 1, 2, 3
CLASS_NAMES = {0: 'not managed', FREE: 'Free', RESERVED: 'Reserved', TDE: 'TDE'}


def format_word(access_class: int, representation: int, digits: int, decimals: int) -> int:
    """The 16-bit format word: class | representation | integer digits | decimals."""
    return (access_class & 0xF) << 12 | (representation & 0xF) << 8 | (digits & 0xF) << 4 | decimals & 0xF


def decode_format(word: int) -> tuple[int, int, int, int]:
    """(class, representation, integer digits, decimals) of a format word."""
    return word >> 12 & 0xF, word >> 8 & 0xF, word >> 4 & 0xF, word & 0xF


@dataclass(frozen=True)
class Parameter:
    """One P or C entry: ``low``/``high``/``default`` in internal units (unsigned for
    representation 3, as the 16-bit word is read)."""
    letter: str  # 'P' or 'C'
    number: int
    name: str
    word: int  # format word
    low: int
    high: int
    base: int
    default: int

    @property
    def access_class(self) -> int:
        return decode_format(self.word)[0]

    @property
    def representation(self) -> int:
        return decode_format(self.word)[1]

    @property
    def label(self) -> str:
        return f'{self.letter}{self.number}'

    def internal(self, raw16: int) -> int:
        """The INT16 array element as this entry's representation reads it."""
        raw16 &= 0xFFFF
        if self.representation == UNSIGNED:
            return raw16
        return raw16 - 0x10000 if raw16 >= 0x8000 else raw16

    def real(self, raw16: int) -> float:
        """The value in the parameter's own engineering unit (% for percent of base)."""
        v = self.internal(raw16)
        if self.representation == PERCENT:
            return v * 100.0 / self.base
        if self.representation == PROPORTIONAL:
            return v / self.base
        return float(v)

    def words(self) -> list[int]:
        """The 4 words of this entry in 0x2001 / 0x2002 (16-bit, two's complement)."""
        return [w & 0xFFFF for w in (self.word, self.low, self.high, self.base)]


def _p(number: int, name: str, word: int, low: int, high: int, base: int, default: int) -> Parameter:
    return Parameter('P', number, name, word, low, high, base, default)


def _c(number: int, name: str, word: int, low: int, high: int, default: int) -> Parameter:
    return Parameter('C', number, name, word, low, high, 1, default)


PARAMETERS: dict[int, Parameter] = {p.number: p for p in (
    _p(1, 'free percentage (format of example 1, §6.6)', 0x1131, 0, 8190, 4095, 4095),
    _p(2, 'reserved proportional (format of example 2, §6.7)', 0x2231, 5, 1000, 10, 400),
    _p(3, 'free signed direct value', format_word(FREE, DIRECT, 5, 0), -10000, 10000, 1, 0),
    _p(4, 'TDE percentage (service level, key P99)', format_word(TDE, PERCENT, 3, 1), 0, 4095, 4095, 2048),
    _p(54, 'monitor sample period (PWM periods)', format_word(FREE, UNSIGNED, 4, 0), 1, 1000, 1, 1),
    _p(55, 'monitor post-trigger points', format_word(FREE, UNSIGNED, 4, 0), 0, 2000, 1, 1000),
    _p(56, 'monitor trigger level (percent of 4095)', format_word(FREE, PERCENT, 3, 1), -4095, 4095, 4095, 0),
    _p(60, 'key of the Reserved parameters', format_word(FREE, UNSIGNED, 5, 0), 0, 65535, 1, 0),
    _p(99, 'key of the TDE parameters', format_word(FREE, UNSIGNED, 5, 0), 0, 65535, 1, 0),
    _p(162, 'CAN node id', format_word(FREE, DIRECT, 3, 0), 1, 127, 1, 1),
    _p(163, 'alarm enable mask (0x2019)', format_word(FREE, UNSIGNED, 5, 0), 0, 0xFFFF, 1, 0xFFFF),
)}

CONNECTIONS: dict[int, Parameter] = {c.number: c for c in (
    *(_c(n, f'function of terminal input {n} (I00..I28 standard, I29..I63 application)', 0x2020, 0, 63, d)
      for n, d in ((1, 0), (2, 5), (3, 1), (4, 2), (5, 3), (6, 4), (7, 6), (8, 7))),
    _c(14, 'monitor trigger source', format_word(FREE, DIRECT, 2, 0), 0, 63, 0),
    _c(15, 'monitor channel A quantity', format_word(FREE, DIRECT, 2, 0), 0, 63, 0),
    _c(16, 'monitor channel B quantity', format_word(FREE, DIRECT, 2, 0), 0, 63, 1),
    _c(48, 'CAN bit rate code (0 = 1 Mbit/s ... 7 = 10 kbit/s)', format_word(RESERVED, DIRECT, 1, 0), 0, 7, 0),
    _c(52, 'references from CAN (0x201A-0x201D) enabled', format_word(FREE, DIRECT, 1, 0), 0, 1, 1),
    _c(63, 'save parameters to non-volatile memory', format_word(FREE, DIRECT, 1, 0), 0, 1, 0),
)}

# 0x2026 "extra" parameters: 5 words (format, min, max, base, default); no object holds their values
EXTRA: dict[int, tuple[int, int, int, int, int]] = {
    0: (0x1131, 0, 8190, 4095, 4095),  # the appendix's example 1 (§6.10)
    1: (format_word(RESERVED, PROPORTIONAL, 3, 2), 0, 10000, 100, 250),
}

P60, P99, P162, P163 = 60, 99, 162, 163
C48, C52, C63 = 48, 52, 63
