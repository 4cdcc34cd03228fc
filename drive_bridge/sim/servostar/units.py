"""The simulated SERVOSTAR's units [5]: the model's counts (2^20 per revolution) against the
PRBASE increments, the 2020h user units (PGEARI / PGEARO), the factors 0x6093 / 0x6094 of the
CiA 402 position and velocity objects, VLIM, the ramp times that become accelerations, and
the interpolation period 60C2h in PTBASE's units."""
from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.sim.servostar.objects import (
    ABORT_INVALID_VALUE,
    ACC,
    COUNTS_PER_REV,
    DEC,
    DECSTOP,
    INTERPOLATION_PERIOD,
    POSITION_CONTROLLER,
    POSITION_FACTOR,
    SAMPLE,
    VALUE,
    VELOCITY_FACTOR,
    VLIM,
)
from drive_bridge.sim.store import key


class Units:
    """One axis' conversions, read live from ``values``; ``prbase`` as read at boot."""

    def __init__(self, values: Mapping[int, Any], options: Callable[[], Mapping[str, Any]]) -> None:
        self._values = values
        self._options = options
        self.prbase = 20

    def prbase_scale(self) -> float:
        """2^PRBASE increments per 2^20 counts."""
        return 2.0 ** (self.prbase - 20)

    def actual_scale(self) -> float:
        """0x2070:03: 2^20 per revolution, or 2^PRBASE with the option actual_position_resolution."""
        return self.prbase_scale() if self._options()['actual_position_resolution'] == 'prbase' else 1.0

    def gear(self) -> float:
        """2020h user units ("um") per count: PGEARI / PGEARO."""
        out = self._values.get(key(POSITION_CONTROLLER, 8), 1) or 1
        return float((self._values.get(key(POSITION_CONTROLLER, 9), 1) or 1) / out)

    def counts_to_user(self, counts: float) -> float:
        return counts * self.gear()

    def user_to_counts(self, value: float) -> float:
        return float(value) / self.gear()

    def position_factor(self) -> float:
        """0x6093: user units of 6064h / 607Ah per count."""
        numerator = self._values.get(key(POSITION_FACTOR, 1), COUNTS_PER_REV) or COUNTS_PER_REV
        return float((self._values.get(key(POSITION_FACTOR, 2), 10000) or 1) / numerator)

    def counts_to_position_units(self, counts: float) -> float:
        return counts * self.position_factor()

    def velocity_factor(self) -> float:
        """counts/s per velocity unit (0x6094; 0/0: increments per 250 us)."""
        numerator = self._values.get(key(VELOCITY_FACTOR, 1), 0)
        divisor = self._values.get(key(VELOCITY_FACTOR, 2), 0)
        return float(numerator / divisor) if numerator and divisor else 1.0 / SAMPLE

    def counts_to_velocity_units(self, counts_per_s: float) -> float:
        return counts_per_s / self.velocity_factor()

    def vlim(self) -> float:
        """VLIM (rpm) in counts/s."""
        return max(1.0, float(self._values.get(key(VLIM, VALUE), 3000)) * COUNTS_PER_REV / 60.0)

    @staticmethod
    def ramp(time_ms: float, speed: float) -> float:
        """The acceleration of a ramp time (ms from 0 to ``speed``)."""
        return max(1.0, speed) / max(float(time_ms), 1.0) * 1000.0

    def emergency_deceleration(self) -> float:
        """DECSTOP: the emergency (quick-stop) ramp, ms from VLIM to 0."""
        return self.ramp(self._values.get(key(DECSTOP, VALUE), 10), self.vlim())

    def ramps(self, profile_velocity: float, speed_mode: bool) -> dict[str, float]:
        """The motion parameters the SERVOSTAR's ramp times and VLIM give: ACC / DEC (or 6083h /
        6084h when set) as accelerations referred to VLIM in the speed modes, else to the profile
        velocity; the speed and pv ramps; DECSTOP as the quick-stop and maximum deceleration."""
        values = self._values
        vlim = self.vlim()
        profile = min(profile_velocity, vlim)
        acc = values.get(key(obj.PROFILE_ACCELERATION), 0) or values.get(key(ACC, VALUE), 10)
        dec = values.get(key(obj.PROFILE_DECELERATION), 0) or values.get(key(DEC, VALUE), 10)
        emergency = self.emergency_deceleration()
        reference = vlim if speed_mode else profile  # ramp times refer to VLIM in the speed modes
        return dict(motor_speed=vlim * 1.25, max_velocity=vlim, profile_velocity=profile,
                    acceleration=self.ramp(acc, reference), deceleration=self.ramp(dec, reference),
                    speed_acceleration=self.ramp(values.get(key(ACC, VALUE), 10), vlim),
                    speed_deceleration=self.ramp(values.get(key(DEC, VALUE), 10), vlim),
                    pv_acceleration=self.ramp(acc, vlim), pv_deceleration=self.ramp(dec, vlim),
                    quick_stop_deceleration=emergency, max_deceleration=emergency)


def check_interpolation_period(values: Mapping[int, Any], sub: int, value: int) -> None:
    """A write of 60C2h:``sub``: whole ms only, within PTBASE's range (abort 0x06090030)."""
    units = value if sub == 1 else values.get(key(INTERPOLATION_PERIOD, 1), 1)
    index = value if sub == 2 else values.get(key(INTERPOLATION_PERIOD, 2), -3)
    period_ms = units * 10.0 ** (index + 3)
    if period_ms < 1.0 - 1e-9 or abs(period_ms - round(period_ms)) > 1e-6 or round(period_ms) * 4 > 127:
        raise SdoAbortedError(ABORT_INVALID_VALUE)


def ptbase_of_period(values: Mapping[int, Any]) -> int:
    """60C2h as PTBASE (units of 250 us; effective after save and restart, as PTBASE itself)."""
    units = values.get(key(INTERPOLATION_PERIOD, 1), 1)
    index = values.get(key(INTERPOLATION_PERIOD, 2), -3)
    return int(round(units * 10.0 ** (index + 3))) * 4
