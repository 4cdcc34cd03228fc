"""The representation words of the OPEN drive's actual values (appendix §2.6.4 Tab_exp_int 0x2003,
§2.6.5 Tab_exp_osc 0x2004; opendrive.md §3.3, §3.4): one 16-bit word per element of Tab_int
0x200F / Tab_osc 0x2012, 64 words, a DOMAIN read by segmented upload. The bridge reads them at
boot and scales the velocity and torque feedback by them, not by a fixed 16384 = n_MAX.

The nibble diagram of the word is lost; the appendix's three examples give 0x0002 "percentage
of 4095" (2040 -> 49.8 %), 0x0003 "percentage of 32767" (5000 -> 15.2 %) and 0x0041 "direct
value divided by 2^4" (120 -> 7.5). Read here: low nibble 2 / 3 the percentages, low nibble 1 a
direct value divided by 2^n with n in bits 4..7, every other nibble 0; any other word is not
understood and fails the boot naming it. What 100 % (a direct 1.0) of the quantity is, the
appendix leaves to the product documentation: the bridge takes n_MAX for the speed and T_nom
for the torque, the bases of the references 0x201A (16384 = n_MAX) and 0x201C (4095 = T_nom).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass

from drive_bridge.families.opendrive import objects as od

FORMATS_INT = 0x2003  # Tab_exp_int: the words of Tab_int 0x200F
FORMATS_OSC = 0x2004  # Tab_exp_osc: the words of Tab_osc 0x2012
FORMATS_OF = {od.TAB_INT: FORMATS_INT, od.TAB_OSC: FORMATS_OSC}
PERCENT_4095, PERCENT_32767, DIRECT = 0x0002, 0x0003, 0x0001
FORMS = '0x0002 (% of 4095), 0x0003 (% of 32767) or 0x00n1 (direct / 2^n)'


def full_scale(word: int) -> float:
    """The raw value of 100 % (a direct 1.0) a representation word gives; ValueError for a word
    outside the three forms of the appendix (module docstring)."""
    if word == PERCENT_4095:
        return 4095.0
    if word == PERCENT_32767:
        return 32767.0
    if word & 0xFF0F == DIRECT:
        return float(1 << (word >> 4 & 0xF))
    raise ValueError(f'representation word 0x{word:04X} is not one the appendix shows: {FORMS}')


def words(table: bytes) -> tuple[int, ...]:
    """The 16-bit little-endian words of a 0x2003 / 0x2004 upload (ValueError if not 64 of them)."""
    if len(table) != 2 * od.TABLE_ELEMENTS:
        raise ValueError(f'{len(table)} bytes, expected {2 * od.TABLE_ELEMENTS} (64 words)')
    return struct.unpack(f'<{od.TABLE_ELEMENTS}H', table)


@dataclass(frozen=True)
class Scaling:
    """The raw value of n_MAX in the velocity feedback and of T_nom in the torque feedback (the
    defaults: as the references, before the boot read the words)."""

    velocity_full_scale: float = 16384.0
    torque_full_scale: float = 4095.0
    velocity_word: int | None = None
    torque_word: int | None = None
