"""Bus load over time: bits per time bin, nominal (as drive_bridge.master.busload counts them)
and with the worst-case stuff bits (Davis et al.: floor((g + 8n - 1) / 4), g = 34 / 54)."""
from __future__ import annotations

from typing import Any

from drive_bridge.master.busload import EXTENDED_EXTRA_BITS, FRAME_OVERHEAD_BITS

BIN_S = 0.1
# by payload length 0..8 (longer DLCs of CAN FD are not classic frames: counted as 8)
NOMINAL = [FRAME_OVERHEAD_BITS + 8 * n for n in range(9)]
STUFF = [(34 + 8 * n - 1) // 4 for n in range(9)]
EXT_NOMINAL = [b + EXTENDED_EXTRA_BITS for b in NOMINAL]
EXT_STUFF = [(54 + 8 * n - 1) // 4 for n in range(9)]


class BusLoad:
    """The engine adds each frame's bits to ``nominal[bin]`` / ``stuffed[bin]``."""

    def __init__(self, bitrate: int | None) -> None:
        self.bitrate = bitrate
        self.nominal: list[int] = []
        self.stuffed: list[int] = []

    def grow(self, size: int) -> None:
        extra = size - len(self.nominal)
        self.nominal.extend([0] * extra)
        self.stuffed.extend([0] * extra)

    def peak(self) -> tuple[float, float]:
        """(bits/s nominal, bits/s worst case) of the busiest bin."""
        if not self.nominal:
            return 0.0, 0.0
        return max(self.nominal) / BIN_S, max(self.stuffed) / BIN_S

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
