"""The references the simulated OPEN drive applies, from its fieldbus objects and only while
C52 = 1 selects them: the speed from 0x201A (16384 = n_MAX) or as the angle increment 0x201D
per PWM period, the torque 0x201C and its limit 0x201E (4095 = T_nom)."""
from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from drive_bridge.sim.opendrive import objects as o
from drive_bridge.sim.store import key


def speed_reference(values: Mapping[int, Any], options: Mapping[str, Any], selected: bool, n_max: float) -> float:
    """rad/s (0 unless ``selected``: C52 = 1); ``n_max`` in rad/s."""
    if not selected:
        return 0.0
    if options['speed_reference'] == '0x201A':
        return values[key(o.F_FIELDBUS)] / o.SPEED_FULL_SCALE * n_max
    return values[key(o.THETA_FIELDBUS)] * options['pwm_frequency'] * 2.0 * math.pi / (
        o.PULSES_PER_REVOLUTION * options['pole_pairs'])


def torque_reference(values: Mapping[int, Any], options: Mapping[str, Any], selected: bool) -> tuple[float, float]:
    """(torque reference, torque limit) in N m; without ``selected`` 0 and the full limit."""
    rated = options['rated_torque']
    if selected:
        return (values[key(o.TRIF_FIELDBUS)] / o.TORQUE_FULL_SCALE * rated,
                abs(values[key(o.LIMIT_FIELDBUS)]) / o.TORQUE_FULL_SCALE * rated)
    return 0.0, 32767 / o.TORQUE_FULL_SCALE * rated
