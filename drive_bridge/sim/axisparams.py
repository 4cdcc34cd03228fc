"""The motion parameters of a simulated CiA 402 axis, derived from its objects: the profile
velocity, acceleration and decelerations within their maxima (0x6080, 0x607F, 0x60C5, 0x60C6),
the quick-stop ramp 0x6085, the torque limit 0x6072, the software position limits 0x607D
(active when min < max), the interpolation time period 0x60C2 and the following error window
and timeout (0x6065, 0x6066). A limit the dictionary does not give does not limit."""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from drive_bridge.cia402 import objects as obj

# the objects (index for axis 0, sub-index) whose write invalidates the derived parameters
CACHED_PARAMETERS = (
    (obj.MAX_MOTOR_SPEED, 0), (obj.MAX_PROFILE_VELOCITY, 0), (obj.PROFILE_VELOCITY, 0),
    (obj.PROFILE_ACCELERATION, 0), (obj.PROFILE_DECELERATION, 0), (obj.MAX_ACCELERATION, 0),
    (obj.MAX_DECELERATION, 0), (obj.QUICK_STOP_DECELERATION, 0), (obj.MAX_TORQUE, 0),
    (obj.SOFTWARE_POSITION_LIMIT, 1), (obj.SOFTWARE_POSITION_LIMIT, 2), (obj.INTERPOLATION_TIME_PERIOD, 1),
    (obj.INTERPOLATION_TIME_PERIOD, 2), (obj.FOLLOWING_ERROR_WINDOW, 0), (obj.FOLLOWING_ERROR_TIMEOUT, 0),
)


def derive_motion_parameters(p: Callable[..., Any]) -> dict[str, Any]:
    """The parameters by name, from ``p(index, subindex=0, default=None)``, the axis' reader."""
    inf = math.inf
    motor = float(p(obj.MAX_MOTOR_SPEED, default=inf))
    v_max = float(min(p(obj.MAX_PROFILE_VELOCITY, default=inf), motor))
    max_dec = float(p(obj.MAX_DECELERATION, default=inf))
    dec = max(1.0, float(min(p(obj.PROFILE_DECELERATION, default=inf), max_dec)))
    low = p(obj.SOFTWARE_POSITION_LIMIT, 1, default=0)
    high = p(obj.SOFTWARE_POSITION_LIMIT, 2, default=0)
    units = p(obj.INTERPOLATION_TIME_PERIOD, 1, default=0)
    period = units * 10.0 ** p(obj.INTERPOLATION_TIME_PERIOD, 2, default=-3)
    return {
        'motor_speed': motor,
        'max_velocity': v_max,
        'profile_velocity': min(float(p(obj.PROFILE_VELOCITY, default=inf)), v_max),
        'acceleration': max(1.0, float(min(p(obj.PROFILE_ACCELERATION, default=inf),
                                           p(obj.MAX_ACCELERATION, default=inf)))),
        'deceleration': dec,
        'quick_stop_deceleration': max(1.0, float(p(obj.QUICK_STOP_DECELERATION, default=dec))),
        'max_deceleration': max(1.0, min(max_dec, 1e12)),
        'torque_limit': float(p(obj.MAX_TORQUE, default=32767)),
        'interpolation_period': period if 1e-5 <= period <= 10.0 else None,
        'software_limits': (float(low), float(high)) if low < high else None,
        'fe_window': p(obj.FOLLOWING_ERROR_WINDOW, default=0xFFFFFFFF),
        'fe_timeout': p(obj.FOLLOWING_ERROR_TIMEOUT, default=0) / 1000.0,
    }
