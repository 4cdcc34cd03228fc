"""The AKD's EMCY frames [2.6]: byte 3 ("category") is 1 in every error or warning frame
(0 in the reset frame), and warnings (nXXX) are sent and logged in 0x1003 but do not enter
the error register."""
from __future__ import annotations

from drive_bridge.sim.akd.objects import CATEGORY
from drive_bridge.sim.emcy import EmcyProducer


class AkdEmcy(EmcyProducer):
    """EMCY with the AKD's category byte, and warnings."""

    def error(self, code: int, source: str = 'device', manufacturer: bytes = b'',
              transient: bool = False, emit: bool = True) -> None:
        super().error(code, source, manufacturer or CATEGORY, transient, emit)

    def warning(self, code: int) -> None:
        """A warning's EMCY: the error register as it is (faults only), category 1."""
        self.push_history(code)
        self.emit(code, self.register, CATEGORY)
