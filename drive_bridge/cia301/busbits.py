"""Bits of one classic CAN frame on the wire: one calculator for the live bus load, the
configuration's bus budget and a recorded trace's load, so their figures agree."""
from __future__ import annotations

FRAME_OVERHEAD_BITS = 47  # data frame with an 11-bit id, no stuff bits, plus the 3-bit intermission
EXTENDED_EXTRA_BITS = 20  # a 29-bit id: 18 more id bits, SRR and IDE


def stuff_bits(data_bytes: int, extended: bool = False) -> int:
    """Worst-case stuff bits (Davis et al.: floor((g + 8n - 1) / 4), g = 34 or 54)."""
    return ((54 if extended else 34) + 8 * data_bytes - 1) // 4


def frame_bits(data_bytes: int, extended: bool = False, remote: bool = False, stuffed: bool = False) -> int:
    """Bits of a frame with ``data_bytes`` bytes (a remote frame carries none); ``stuffed``:
    with the worst-case stuff bits (8 bytes: 135, SYNC: 55), else nominal (8 bytes: 111)."""
    data = 0 if remote else data_bytes
    bits = FRAME_OVERHEAD_BITS + 8 * data + (EXTENDED_EXTRA_BITS if extended else 0)
    return bits + (stuff_bits(data, extended) if stuffed else 0)
