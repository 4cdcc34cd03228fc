"""EMCY timeline (0x080 + node) with texts: the drive family's ``decode_emcy`` when the
config names a family, else CiA 301/402's table."""
from __future__ import annotations

from dataclasses import dataclass

from drive_bridge.bag.diagnose.model import Context, Severity
from drive_bridge.cia301.emcy import EmcyEvent, Severity as EmcySeverity, decode_emcy

_SEVERITY = {EmcySeverity.INFO: Severity.INFO, EmcySeverity.WARNING: Severity.WARNING,
             EmcySeverity.ERROR: Severity.ERROR}


@dataclass(frozen=True, slots=True)
class EmcyRecord:
    time: float  # s since t0
    node: int
    event: EmcyEvent
    dlc: int

    @property
    def text(self) -> str:
        register = f'; register 0x{self.event.register:02X} ({self.event.register_text})' \
            if self.event.register else ''
        short = f' (DLC {self.dlc})' if self.dlc < 8 else ''
        return f'EMCY 0x{self.event.code:04X} {self.event.text}{register}{short}'


class EmcyTimeline:
    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.records: list[EmcyRecord] = []
        self.last_fault: dict[int, EmcyRecord] = {}

    def frame(self, t: float, cob: int, data: bytes | bytearray) -> None:
        node = cob - 0x80
        info = self.ctx.nodes.get(node)
        raw = bytes(data)
        if info is not None and info.family is not None:
            event = info.family.decode_emcy(node, info.name, raw, t)
        else:
            event = decode_emcy(node, info.name if info else '', raw, t)
        record = EmcyRecord(t - self.ctx.t0, node, event, len(raw))
        self.records.append(record)
        if event.is_reset:
            self.last_fault.pop(node, None)
            return
        self.last_fault[node] = record
        severity = _SEVERITY[event.severity]
        self.ctx.add(severity, t, node, record.text, self._cause(event), 'emcy', slot=event.slot)

    @staticmethod
    def _cause(event: EmcyEvent) -> str:
        """What to check, by the code's class (CiA 301 Table 21: the high nibble / byte)."""
        group = event.code >> 8
        if group in _GROUP_CAUSES:
            return _GROUP_CAUSES[group]
        return _CLASS_CAUSES.get(event.code >> 12, 'the drive reports a fault; its manual explains the code')


_CLASS_CAUSES = {  # EMCY code >> 12
    0x2: 'electrical: check the supply, the motor wiring and the drive\'s current limits',
    0x3: 'voltage: check the supply and the DC link (braking resistor on deceleration)',
    0x4: 'over-temperature: check cooling and the load',
    0x5: 'device hardware: the drive reports an internal fault',
    0x6: 'device software: the drive reports an internal (firmware) fault',
    0x7: 'an additional module (encoder, sensor): check its wiring',
}
_GROUP_CAUSES = {  # EMCY code >> 8
    0x81: 'CANopen communication: the node reports a bus or life-guard / heartbeat problem',
    0x82: 'a PDO was shorter or longer than its mapping (protocol error)',
    0x84: 'motion control: velocity or speed limit; check the trajectory and tuning',
    0x86: 'motion control: following error or position limit; check the trajectory, load and tuning',
    0x87: 'motion control: the interpolation buffer / SYNC timing of the stream',
}
