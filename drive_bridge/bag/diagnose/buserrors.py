"""CAN error frames as bus errors, with what SocketCAN's error class and controller state say
(linux/can/error.h): a node that lost arbitration, got no ACK, went error passive or bus off."""
from __future__ import annotations

from drive_bridge.bag.diagnose.model import Context, Severity

CLASSES = ((0x001, 'TX timeout'), (0x002, 'lost arbitration'), (0x004, 'controller problems'),
           (0x008, 'protocol violations'), (0x010, 'transceiver status'), (0x020, 'no ACK on transmission'),
           (0x040, 'bus off'), (0x080, 'bus error'), (0x100, 'controller restarted'))
CONTROLLER = ((0x01, 'RX buffer overflow'), (0x02, 'TX buffer overflow'), (0x04, 'RX error warning'),
              (0x08, 'TX error warning'), (0x10, 'RX error passive'), (0x20, 'TX error passive'),
              (0x40, 'back to error active'))
SEVERE = 0x040 | 0x020  # bus off, no ACK: nothing gets through


class BusErrors:
    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.count = 0
        self.first = 0.0
        self.classes = 0
        self.controller = 0

    def frame(self, t: float, ident: int, data: bytes | bytearray) -> None:
        if not self.count:
            self.first = t
        self.count += 1
        self.classes |= ident & 0x1FF
        if ident & 0x004 and len(data) > 1:
            self.controller |= data[1]

    def texts(self) -> list[str]:
        out = [name for bit, name in CLASSES if self.classes & bit and bit != 0x004]
        out += [name for bit, name in CONTROLLER if self.controller & bit]
        return out or (['controller problems'] if self.classes & 0x004 else [])

    def finish(self) -> None:
        if not self.count:
            return
        passive = self.controller & 0x30
        severity = Severity.ERROR if self.classes & SEVERE or passive else Severity.WARNING
        kinds = ', '.join(self.texts()) or 'class not given'
        self.ctx.add(severity, self.first, None, f'{self.count} CAN error frame(s): {kinds}',
                     'bus errors: termination (120 ohm at both ends), wiring, a node with another bit rate, '
                     'or a faulty node; no ACK: no other node on the bus, or none at this bit rate',
                     'bus-errors', short=f'{self.count} CAN bus error(s) ({kinds})')
