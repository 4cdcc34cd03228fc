"""The SERVOSTAR's EMCY frames [2.10, 3.1-3.4]: byte 3 is the error category, bytes 4..7 are
zero; every error EMCY is followed by a second EMCY with code 0x0000 carrying the error register
as it is now (and the category); an error reset sends 0x0000 with the remaining register (0
once none is left), also when only some errors went. 0x1003 keeps the last error only (its
size comes from the EDS)."""
from __future__ import annotations

from drive_bridge.sim.emcy import EmcyProducer
from drive_bridge.sim.servostar.objects import CATEGORIES


def category_of(code: int, source: str = 'device') -> int:
    """The EMCY table's category of ``code``; unknown codes: 3 for PDO processing errors, else 1."""
    return CATEGORIES.get(code, 3 if source == 'pdo' else 1)


class ServostarEmcy(EmcyProducer):
    """EMCY with the category byte and the follow-up frame (module docstring)."""

    def error(self, code: int, source: str = 'device', manufacturer: bytes = b'',
              transient: bool = False, emit: bool = True) -> None:
        category = manufacturer[:1] or bytes([category_of(code, source)])
        super().error(code, source, category, transient, emit)
        if emit:
            self._emit(0x0000, self.register, category)  # the error state after every EMCY

    def clear(self, source: str | None = None, keep: frozenset[int] = frozenset()) -> None:
        """Forget the errors of ``source`` (all if None) but the codes in ``keep``; EMCY 0x0000
        with the remaining error register if any went."""
        before = len(self._active)
        self._active = {k: v for k, v in self._active.items()
                        if (source is not None and k[0] != source) or k[1] in keep}
        if len(self._active) != before:
            self._emit(0x0000, self.register, b'')

    def codes(self, source: str) -> list[int]:
        return [code for (s, code) in self._active if s == source]
