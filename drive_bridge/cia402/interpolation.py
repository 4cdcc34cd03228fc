"""The interpolation objects of one axis, written by SDO off the cycle: the period 0x60C2 (CSP
and IP interpolate over the SYNC period), the IP sub-mode 0x60C0 and the buffer 0x60C4 (cleared
before a stream, so no point left queued runs on its own). Objects the drive lacks are skipped."""
from __future__ import annotations

from collections.abc import Mapping

from drive_bridge.errors import DriveBridgeError
from drive_bridge.joint import NodeIo


class InterpolationObjects:
    """0x60C0, 0x60C2 and 0x60C4 of one axis (by the axis' key names)."""

    def __init__(self, node: NodeIo, key: Mapping[str, tuple[int, int]], cycle_period: float) -> None:
        self.node = node
        self.key = key
        self.cycle_period = cycle_period  # s: the SYNC period

    def _write(self, writes: list[tuple[str, int]]) -> None:
        for name, value in writes:
            if self.node.has_object(*self.key[name]):
                self.node.sdo_write(*self.key[name], value)

    def period_writes(self) -> list[tuple[str, int]]:
        """0x60C2:1/2 for the SYNC period: in ms where it is whole, else in 100 us units."""
        period_ms = self.cycle_period * 1000.0
        if abs(period_ms - round(period_ms)) < 1e-6 and 1 <= round(period_ms) <= 255:
            return [('ip_units', round(period_ms)), ('ip_index', -3)]
        return [('ip_units', round(period_ms * 10)), ('ip_index', -4)]  # 100 us units

    def prepare(self, ip_submode: int) -> None:
        """Before entering IP: sub-mode (0x60C0), period = the SYNC period (0x60C2, both
        sub-indices, in ms: the only unit many drives take), and a cleared buffer (0x60C4:6)."""
        self._write([('ip_submode', ip_submode), *self.period_writes(), ('ip_clear', 0), ('ip_clear', 1)])

    def write_period(self, interpolated: bool, ip_submode: int) -> None:
        """The SYNC period into 0x60C2, and for IP the sub-mode and a cleared buffer; objects the
        drive keeps fixed are left as they are."""
        try:
            if interpolated:
                self.prepare(ip_submode)
            else:
                self._write(self.period_writes())
        except DriveBridgeError:
            pass  # read-only on this drive (its EDS makes it const): the drive's own period

    def clear_buffer(self) -> None:
        """0x60C4:6 = 0, then 1: the drive's interpolation buffer emptied."""
        self._write([('ip_clear', 0), ('ip_clear', 1)])
