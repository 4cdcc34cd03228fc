"""EMCY timeline (0x080 + node) with texts: the drive family's ``decode_emcy`` when the
config names a family, else CiA 301/402's table. What an EMCY means beside its code: a vendor
communication EMCY right after the master's own NMT reset of the node is a notice of that
reset (no fault); a repeated EMCY that each time follows the same frame is triggered by it
(usually a PDO whose length does not match the receiver's mapping)."""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, replace

from drive_bridge.bag.diagnose.model import Context, Finding, Severity
from drive_bridge.bag.diagnose.nmt import NmtTimeline
from drive_bridge.cia301.emcy import EmcyEvent, Severity as EmcySeverity, decode_emcy

_SEVERITY = {EmcySeverity.INFO: Severity.INFO, EmcySeverity.WARNING: Severity.WARNING,
             EmcySeverity.ERROR: Severity.ERROR}
NOTICE_S = 0.5  # a communication EMCY this soon after a commanded boot-up reports the reset
CIA301_COMMUNICATION = frozenset({0x8100, 0x8110, 0x8120, 0x8130, 0x8140, 0x8150})  # real CAN problems
REPEATED = 5  # this many identical EMCYs are a pattern worth explaining
TRIGGER_SHARE = 0.8  # ... when this share of them follows frames of one COB-ID


@dataclass(slots=True)
class EmcyRecord:
    time: float  # s since t0
    node: int
    event: EmcyEvent
    dlc: int
    notice: bool = False  # a notice of the master's own NMT reset, not a fault
    after: int | None = None  # the COB-ID of the frame just before it
    finding: Finding | None = None
    seq: int = 0  # event sequence number (Context.events)

    @property
    def text(self) -> str:
        register = f'; register 0x{self.event.register:02X} ({self.event.register_text})' \
            if self.event.register else ''
        short = f' (DLC {self.dlc})' if self.dlc < 8 else ''
        return f'EMCY 0x{self.event.code:04X} {self.event.text}{register}{short}'


def cob_label(cob: int) -> str:
    """'RPDO1 of node 3', 'SYNC', ... for a COB-ID of the predefined connection set."""
    node = cob & 0x7F
    if cob == 0x80:
        return 'SYNC'
    if cob == 0:
        return 'NMT'
    if 0x181 <= cob <= 0x57F and node:
        fc = cob >> 7
        return f'{"TPDO" if fc % 2 else "RPDO"}{(fc - 1) // 2} of node {node}'
    if 0x581 <= cob <= 0x5FF:
        return f'SDO response of node {node}'
    if 0x601 <= cob <= 0x67F:
        return f'SDO request to node {node}'
    if 0x701 <= cob <= 0x77F:
        return f'heartbeat of node {node}'
    return f'COB-ID 0x{cob:03X}'


class EmcyTimeline:
    def __init__(self, ctx: Context, nmt: NmtTimeline) -> None:
        self.ctx = ctx
        self.nmt = nmt
        self.records: list[EmcyRecord] = []
        self.last_fault: dict[int, EmcyRecord] = {}
        self.prev_cob: int | None = None  # the engine sets it before each EMCY frame

    def frame(self, t: float, cob: int, data: bytes | bytearray) -> None:
        node = cob - 0x80
        info = self.ctx.nodes.get(node)
        raw = bytes(data)
        if info is not None and info.family is not None:
            event = info.family.decode_emcy(node, info.name, raw, t)
        else:
            event = decode_emcy(node, info.name if info else '', raw, t)
        self.ctx.events += 1
        record = EmcyRecord(t - self.ctx.t0, node, event, len(raw), after=self.prev_cob, seq=self.ctx.events)
        self.records.append(record)
        if event.is_reset:
            self.last_fault.pop(node, None)
            return
        boot = self.nmt.commanded_boot(node)
        if boot is not None and t - boot <= NOTICE_S and event.code & 0xFF00 == 0x8100 \
                and event.code not in CIA301_COMMUNICATION:
            record.notice = True
            record.finding = self.ctx.add(
                Severity.INFO, t, node, record.text,
                'a notice of the NMT reset the master sent the node just before (its CAN state changed), no fault',
                'emcy', slot=event.slot)
            return
        self.last_fault[node] = record
        record.finding = self.ctx.add(_SEVERITY[event.severity], t, node, record.text, self._cause(event), 'emcy',
                                      slot=event.slot, short=f'node {node}: EMCY 0x{event.code:04X} {event.text}')

    def fault_before(self, node: int, t: float, window: float) -> EmcyRecord | None:
        """The node's last fault EMCY (no notice, no reset) within ``window`` s before ``t`` (absolute)."""
        record = self.last_fault.get(node)
        if record is None or (self.ctx.timing and t - self.ctx.t0 - record.time > window):
            return None
        return record

    def fault_after(self, node: int, start: int, t: float, window: float) -> EmcyRecord | None:
        """The node's first fault EMCY among records[start:], within ``window`` s after ``t`` (relative)."""
        for record in self.records[start:]:
            if record.node != node or record.notice or record.event.is_reset:
                continue
            if not self.ctx.timing or record.time - t <= window:
                return record
            break
        return None

    def finish(self, master: int | None) -> None:
        """Explain repeated identical EMCYs by the frame each follows, and the master as their sender."""
        groups: dict[tuple[int, int], list[EmcyRecord]] = {}
        for record in self.records:
            if record.finding is not None and not record.notice:
                groups.setdefault((record.node, record.event.code), []).append(record)
        index = {id(f): i for i, f in enumerate(self.ctx.findings)}
        for (node, _code), records in groups.items():
            if len(records) < REPEATED:
                continue
            (cob, hits), = Counter(r.after for r in records).most_common(1)
            parts = []
            if cob is not None and hits >= TRIGGER_SHARE * len(records):
                parts.append(f'{hits} of the {len(records)} identical EMCYs each follow a frame of {cob_label(cob)} '
                             f'(0x{cob:03X}): that frame triggers them'
                             + (' (its length or mapping does not match what the receiver expects)'
                                if 0x181 <= cob <= 0x57F else ''))
            if master is not None and node == master:
                parts.append(f'node {node} is the master (it sends only heartbeats and EMCYs, answers no SDO, sends '
                             'no PDO): its own CANopen stack reports the problem, not a drive')
            if not parts:
                continue
            for record in records:
                finding = record.finding
                if finding is not None and id(finding) in index:
                    self.ctx.findings[index[id(finding)]] = record.finding = replace(
                        finding, cause='; '.join(parts) + f'; {finding.cause}')

    @staticmethod
    def _cause(event: EmcyEvent) -> str:
        """What to check: the code itself, else its group (0xAB00), else its class (0xA000) (CiA 301 / 402)."""
        code = event.code
        for key in (code, code & 0xFFF0):
            if key in _CODE_CAUSES:
                return _CODE_CAUSES[key]
        if code >> 8 in _GROUP_CAUSES:
            return _GROUP_CAUSES[code >> 8]
        return _CLASS_CAUSES.get(code >> 12, 'the drive reports a fault; its manual explains the code')


_CODE_CAUSES = {  # exact codes (and 0xABC0 families) of CiA 301 / CiA 402
    0x7121: 'motor blocked: the motor cannot turn (a mechanical block, the brake not released, a load above '
            'the torque limit)',
    0x7122: 'motor error or commutation malfunction: check the motor phases, the encoder / Hall signals and '
            'the motor parameters',
    0x6310: 'loss of parameters: the stored parameters are gone (non-volatile memory): restore and save them',
    0x6320: 'parameter error: a parameter value is invalid or inconsistent (check the SDO writes of the '
            'configuration before it; restore the defaults)',
    0x8110: 'CAN overrun: the node lost received frames (too many at once: SDO bursts, PDO rate, bus load)',
    0x8120: 'CAN error passive: the node sees many bus errors (termination, wiring, a wrong bit rate)',
    0x8130: 'life guard / heartbeat error: the node missed the master\'s guarding or a heartbeat it consumes',
    0x8140: 'recovered from bus off: the node was off the bus (bus errors) and is back',
    0x8210: 'a PDO it received is shorter than its mapping: the sender\'s PDO does not match this node\'s mapping',
    0x8220: 'a PDO it received is longer than its mapping: the sender\'s PDO does not match this node\'s mapping',
}
_CLASS_CAUSES = {  # EMCY code >> 12
    0x2: 'electrical: check the supply, the motor wiring and the drive\'s current limits',
    0x3: 'voltage: check the supply and the DC link (braking resistor on deceleration)',
    0x4: 'over-temperature: check cooling and the load',
    0x5: 'device hardware: the drive reports an internal fault',
    0x6: 'device software: the drive reports an internal (firmware) fault',
    0x7: 'an additional module (encoder, sensor): check its wiring',
}
_GROUP_CAUSES = {  # EMCY code >> 8
    0x63: 'data set: a parameter set is invalid or lost (check the configuration; restore the defaults)',
    0x71: 'power stage / motor: check the motor, its brake, the braking resistor and the load',
    0x73: 'sensor (encoder, resolver): check its cable, supply and parameters',
    0x75: 'communication inside the drive (an option card or its fieldbus interface)',
    0x76: 'data storage: the drive\'s non-volatile memory',
    0x81: 'CANopen communication: the node reports a bus or life-guard / heartbeat problem',
    0x82: 'a PDO was shorter or longer than its mapping (protocol error)',
    0x84: 'motion control: velocity or speed limit; check the trajectory and tuning',
    0x86: 'motion control: following error or position limit; check the trajectory, load and tuning',
    0x87: 'motion control: the interpolation buffer / SYNC timing of the stream',
}
