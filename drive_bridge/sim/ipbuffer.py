"""The interpolated-position input buffer of one axis (0x60C1 / 0x60C4).

CiA 402 leaves its overflow behaviour open. Here it is a FIFO of
0x60C4:1 records; a point written into a full buffer is dropped and counted, and
the statusword warning bit 7 stays set until the buffer is cleared (0x60C4:6 = 0)
or the axis resets. 0x60C4:6 = 0 clears and disables access (points are then
ignored), 1 enables it again; access is enabled after power-on.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Callable

from canopen.sdo.exceptions import SdoAbortedError

ABORT_VALUE_RANGE = 0x06090030


class IpBuffer:
    """FIFO of IP set-points with the 0x60C4 semantics above."""

    def __init__(self, capacity: Callable[[], int]) -> None:
        self._capacity = capacity
        self._points: deque[int] = deque()
        self.access = True
        self.overflows = 0

    def __len__(self) -> int:
        return len(self._points)

    def __bool__(self) -> bool:
        return bool(self._points)

    @property
    def free(self) -> int:
        """0x60C4:2, actual free buffer size."""
        return max(0, self._capacity() - len(self._points))

    def push(self, value: int) -> None:
        """A written 0x60C1:1."""
        if not self.access:
            return
        if len(self._points) >= self._capacity():
            self.overflows += 1
            return
        self._points.append(int(value))

    def pop(self) -> int:
        return self._points.popleft()

    @staticmethod
    def check_clear(value: int) -> None:
        if value not in (0, 1):
            raise SdoAbortedError(ABORT_VALUE_RANGE)

    def clear(self, value: int) -> None:
        """0x60C4:6 written: 0 clears and disables access, 1 enables access."""
        if value == 0:
            self._points.clear()
            self.overflows = 0
        self.access = value == 1

    def reset(self) -> None:
        self._points.clear()
        self.access, self.overflows = True, 0
