"""Bus load over time: bits per time bin, nominal (as drive_bridge.master.busload counts them)
and with the worst-case stuff bits (Davis et al.: floor((g + 8n - 1) / 4), g = 34 / 54)."""
from __future__ import annotations

from typing import Any

from drive_bridge.bag.diagnose.model import Context, Severity
from drive_bridge.cia301.busbits import EXTENDED_EXTRA_BITS, FRAME_OVERHEAD_BITS

BIN_S = 0.1
# by payload length 0..8 (longer DLCs of CAN FD are not classic frames: counted as 8)
NOMINAL = [FRAME_OVERHEAD_BITS + 8 * n for n in range(9)]
STUFF = [(34 + 8 * n - 1) // 4 for n in range(9)]
EXT_NOMINAL = [b + EXTENDED_EXTRA_BITS for b in NOMINAL]
EXT_STUFF = [(54 + 8 * n - 1) // 4 for n in range(9)]


HIGH_LOAD = 0.8  # above this, frames queue and latencies grow (CiA recommends staying below)


class BusLoad:
    """The engine adds each frame's bits to ``nominal[bin]`` / ``stuffed[bin]``."""

    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.bitrate = ctx.bitrate
        self.nominal: list[int] = []
        self.stuffed: list[int] = []

    def grow(self, size: int) -> None:
        extra = size - len(self.nominal)
        self.nominal.extend([0] * extra)
        self.stuffed.extend([0] * extra)

    def peak(self) -> tuple[float, float]:
        """(bits/s nominal, bits/s with worst-case stuff bits) of the busiest bin."""
        if not self.nominal:
            return 0.0, 0.0
        return max(self.nominal) / BIN_S, max(a + b for a, b in zip(self.nominal, self.stuffed)) / BIN_S

    def finish(self) -> None:
        """A finding for the busiest stretch when it is over ``HIGH_LOAD`` of the bit rate."""
        if not self.bitrate or not self.nominal:
            return
        limit = HIGH_LOAD * self.bitrate * BIN_S
        high = [i for i, bits in enumerate(self.nominal) if bits > limit]
        if not high:
            return
        worst = max(high, key=lambda i: self.nominal[i])
        load = self.nominal[worst] / BIN_S / self.bitrate
        cause = ('more bits than the bit rate carries: the bit rate given is not the bus\'s, or the trace\'s '
                 'time stamps are coarse' if load > 1.0 else
                 'frames queue behind each other: fewer or shorter PDOs, or a longer SYNC period')
        self.ctx.add(Severity.WARNING, self.ctx.t0 + worst * BIN_S, None,
                     f'bus load {load:.0%} of {self.bitrate // 1000} kbit/s (nominal bits) in '
                     f'{len(high)} of {len(self.nominal)} {BIN_S * 1000:.0f} ms bins over {HIGH_LOAD:.0%}', cause,
                     'bus-load')

    def to_json(self) -> dict[str, Any]:
        peak, peak_stuffed = self.peak()
        total = sum(self.nominal)
        duration = len(self.nominal) * BIN_S
        out: dict[str, Any] = {'bin_s': BIN_S, 'bitrate': self.bitrate,
                               'mean_bits_per_s': total / duration if duration else 0.0,
                               'peak_bits_per_s': peak, 'peak_bits_per_s_worst_stuffing': peak_stuffed}
        if self.bitrate:
            out['peak_load'] = peak / self.bitrate
            out['peak_load_worst_stuffing'] = peak_stuffed / self.bitrate
        return out
