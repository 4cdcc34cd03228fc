"""The simulated S120's telegram monitoring [2.4, §2.10]: the mean interval of each RPDO's
frames, against twice the CU's sampling time p8848. A08751 comes once an RPDO arrives faster on
average, and goes once none of its drive object's RPDOs does (or they stopped coming)."""
from __future__ import annotations

import math
from collections.abc import Callable

TELEGRAM_SAMPLES = 8  # intervals averaged before A08751 can be raised
TELEGRAM_WEIGHT = 0.1  # of the newest interval in the running mean (a cycle, not one late frame)
TELEGRAM_JITTER = 0.97  # a cycle on average at 2 x p8848 is in spec: SYNC jitter does not raise A08751
TELEGRAM_HYSTERESIS = 1.05  # A08751 goes when the mean interval is this much above 2 x p8848
TELEGRAM_SILENCE = 1.0  # s without an RPDO: not cyclic any more (A08751 goes)


class _Rate:
    """Mean interval of one RPDO's frames (exponential average)."""

    __slots__ = ('last', 'mean', 'samples')

    def __init__(self) -> None:
        self.last: float | None = None
        self.mean = math.inf
        self.samples = 0

    def update(self, stamp: float) -> None:
        if self.last is not None:
            interval = stamp - self.last
            if interval > TELEGRAM_SILENCE or interval < 0:
                self.mean, self.samples = math.inf, 0
            else:
                self.mean = interval if self.samples == 0 else \
                    (1 - TELEGRAM_WEIGHT) * self.mean + TELEGRAM_WEIGHT * interval
                self.samples += 1
        self.last = stamp


class TelegramMonitor:
    """The RPDO intervals by PDO number; ``minimum`` is 2 x p8848 in s."""

    def __init__(self) -> None:
        self._rates: dict[int, _Rate] = {}

    def clear(self) -> None:
        self._rates.clear()

    def received(self, number: int, stamp: float, minimum: float) -> bool | None:
        """RPDO ``number`` arrived at ``stamp``: True when it comes too fast (A08751), False when
        its mean is back in spec (A08751 may go), None in between."""
        rate = self._rates.setdefault(number, _Rate())
        rate.update(stamp)
        if rate.samples >= TELEGRAM_SAMPLES and rate.mean < minimum * TELEGRAM_JITTER:
            return True
        if rate.mean >= minimum * TELEGRAM_HYSTERESIS:
            return False
        return None

    def in_spec(self, belongs: Callable[[int], bool], now: float, minimum: float) -> bool:
        """Whether none of the RPDOs whose number ``belongs`` still comes too fast at ``now``."""
        for number, rate in self._rates.items():
            if not belongs(number) or rate.last is None or now - rate.last > TELEGRAM_SILENCE:
                continue
            if rate.mean < minimum * TELEGRAM_HYSTERESIS:
                return False
        return True
