"""The OPEN drive's actual values: Tab_osc 0x2012[k] and Tab_int 0x200F[k] (the same quantities
in both, as the simulator keeps them) with their representation words, one per element, in
Tab_exp_osc 0x2004 and Tab_exp_int 0x2003 (appendix §2.6.4, §2.6.5; opendrive.md §3.3).

The nibble diagram of a representation word is lost; the appendix's three examples give:
0x0002 "percentage of 4095" (2040 -> 49.8 %), 0x0003 "percentage of 32767" (5000 -> 15.2 %),
0x0041 "direct value divided by 2^4" (120 -> 7.5). Read here: low nibble 2 / 3 the percentages,
low nibble 1 a direct value divided by 2^n with n in bits 4..7; the rest of the word 0.

What 100 % (or a direct 1.0) of a quantity is, the appendix leaves to the product
documentation: here the speed's is n_MAX and the torque's T_nom, as for the references 0x201A
(16384 = n_MAX) and 0x201C (4095 = T_nom). The speed's word is the option
``actual_speed_representation`` (default 0x00E1: direct / 2^14, so 16384 = n_MAX as 0x201A),
the torque's ``actual_torque_representation`` (default 0x0002); the position is a direct count
(0x0001, 65536 per revolution, wrapping at 16 bits). The decoding of a word is the family's
(drive_bridge.families.opendrive.representation): the one reading of the appendix's examples.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from drive_bridge.families.opendrive.representation import DIRECT, PERCENT_4095, full_scale
from drive_bridge.sim.opendrive.motor import Motor
from drive_bridge.sim.opendrive.objects import PULSES_PER_REVOLUTION

SPEED_DEFAULT = 0x00E1  # direct / 2^14: 16384 = 1.0
TORQUE_DEFAULT = PERCENT_4095
__all__ = ['DIRECT', 'SPEED_DEFAULT', 'TORQUE_DEFAULT', 'actual_value', 'encode', 'full_scale', 'representation']


def encode(fraction: float, word: int) -> int:
    """``fraction`` of the base (1.0 = 100 %) as the INT16 element the word describes (saturated)."""
    return max(-32768, min(32767, int(round(fraction * full_scale(word)))))


def representation(options: Mapping[str, Any], element: int) -> int:
    """The representation word of Tab_osc / Tab_int element ``element``."""
    if element == options['actual_speed_element']:
        return int(options['actual_speed_representation'])
    if element == options['actual_torque_element']:
        return int(options['actual_torque_representation'])
    if element == options['position_element']:
        return DIRECT
    return 0


def actual_value(options: Mapping[str, Any], motor: Motor, n_max: float, element: int) -> int:
    """Tab_osc / Tab_int element ``element`` now (``n_max`` in rad/s)."""
    if element == options['actual_speed_element']:
        return encode(motor.speed / n_max, options['actual_speed_representation'])
    if element == options['actual_torque_element']:
        return encode(motor.torque / options['rated_torque'], options['actual_torque_representation'])
    if element == options['position_element']:
        counts = int(round(motor.angle / (2.0 * math.pi) * PULSES_PER_REVOLUTION)) & 0xFFFF
        return counts - 0x10000 if counts >= 0x8000 else counts
    return 0
