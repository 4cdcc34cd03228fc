"""The node id of the S120's CBC10 [1.3] (manual §4.2.4.2, "Configurazione della velocità di
trasmissione e dell'indirizzo CAN"): at start-up the Control Unit reads its address switch
("DP Address") first; a valid node id there (1..127) is used and shown in p8620, a switch at 0
leaves the node id to p8620. A change of the switch, of p8620 or in STARTER takes effect only
after POWER ON.

Readings where the manual leaves room:

- a switch beyond 127 (the two hex digits reach 255) is no valid node id: p8620 decides, as at 0;
- p8620 counts as it was saved (0x1010:1 "save", p0971): a POWER ON loads the saved parameters,
  so an unsaved p8620 is lost with the power (the SINAMICS' RAM / memory card split);
- the switch's value copied into p8620 is the present (RAM) value, not saved by itself;
- "POWER ON" is the power cycle only; the automatic reboot after p0009 = 0 reads the node id as
  well only with the option ``node_id_at_reboot``.
"""
from __future__ import annotations

VALID_NODE_IDS = range(1, 128)


class AddressSwitch:
    """The Control Unit's address switch: set now, read at the next POWER ON."""

    def __init__(self, value: int) -> None:
        self.value = value

    def set(self, value: int) -> None:
        if not 0 <= value <= 255:
            raise ValueError(f'address switch {value}: two hex digits, 0..255')
        self.value = value

    def node_id(self, p8620: int) -> tuple[int, bool]:
        """(the node id at start-up, whether p8620 shows the switch's value)."""
        if self.value in VALID_NODE_IDS:
            return self.value, True
        return int(p8620), False
