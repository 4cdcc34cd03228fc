"""NMT states as the bridge reports them (CiA 301 §7.3.2)."""
from __future__ import annotations

from enum import Enum

# NMT command specifiers (CiA 301 §7.2.8.3.1) and their names
NMT_COMMANDS = {0x01: 'start', 0x02: 'stop', 0x80: 'enter pre-operational',
                0x81: 'reset node', 0x82: 'reset communication'}


class NmtState(str, Enum):
    """A node's NMT state; a ``str`` enum, so it compares equal to its printed name."""

    INITIALISING = 'INITIALISING'
    STOPPED = 'STOPPED'
    OPERATIONAL = 'OPERATIONAL'
    PRE_OPERATIONAL = 'PRE-OPERATIONAL'
    UNKNOWN = 'UNKNOWN'

    @classmethod
    def from_code(cls, code: int) -> NmtState:
        """The state of a heartbeat / guarding reply byte (bit 7, the guarding toggle, masked)."""
        return _BY_CODE.get(code & 0x7F, cls.UNKNOWN)

    def __str__(self) -> str:
        return self.value


_BY_CODE = {0: NmtState.INITIALISING, 4: NmtState.STOPPED, 5: NmtState.OPERATIONAL,
            127: NmtState.PRE_OPERATIONAL}
