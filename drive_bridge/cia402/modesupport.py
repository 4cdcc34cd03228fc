"""Which modes of operation one axis may be put in: the drive family's list when it gives one
(a drive whose 0x6502 under-reports), else the drive's supported drive modes 0x6502."""
from __future__ import annotations

from drive_bridge.cia402.errors import AxisError
from drive_bridge.cia402.modes import SUPPORT_BITS, Mode, mode_name
from drive_bridge.joint import NodeIo


def _number(value: int | float | str | bytes) -> int:
    """An SDO value that must be a number (the EDS types these objects as integers)."""
    if isinstance(value, (str, bytes)):
        raise AxisError(f'expected a number, the drive sent {value!r}')
    return int(value)


class ModeSupport:
    """The modes an axis takes: ``accepted`` (the family's), else 0x6502 (``supported``, read on
    the first check and at each boot)."""

    def __init__(self, node: NodeIo, key: tuple[int, int], accepted: frozenset[int] | None) -> None:
        self.node = node
        self.key = key  # 0x6502 of the axis' slot
        self.accepted = accepted
        self.supported: int | None = None

    def read(self) -> int | None:
        """0x6502 read from the drive (None: the drive has no 0x6502)."""
        return _number(self.node.sdo_read(*self.key)) if self.node.has_object(*self.key) else None

    def check(self, mode: int, where: str) -> None:
        """Raise AxisError naming the modes the family or the drive takes if ``mode`` is none of them."""
        if self.accepted is not None:
            if mode not in self.accepted:
                names = ', '.join(mode_name(m) for m in sorted(self.accepted))
                raise AxisError(f'{where}: mode {mode_name(mode)} is not accepted by this drive family '
                                f'(it takes {names})')
            return
        if self.supported is None:
            self.supported = self.read()
        supported = self.supported
        if supported is None or mode < 0 or Mode(mode) not in SUPPORT_BITS:
            return
        if not supported >> SUPPORT_BITS[Mode(mode)] & 1:
            names = ', '.join(mode_name(m) for m, bit in SUPPORT_BITS.items() if supported >> bit & 1)
            raise AxisError(f'{where}: mode {mode_name(mode)} is not supported by the drive '
                            f'(0x6502 = 0x{supported:08X}: {names})')
