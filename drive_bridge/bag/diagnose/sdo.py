"""SDO transaction log: requests (0x600 + node) paired with responses (0x580 + node),
expedited and segmented, with latency and abort texts (CiA 301 §7.2.4)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from drive_bridge.bag.diagnose.abort_codes import abort_cause, abort_text
from drive_bridge.bag.diagnose.model import Context, Severity
from drive_bridge.bag.diagnose.names import object_name

NO_ANSWER_S = 1.0  # a request unanswered this long (or overtaken by the next) has no response
_PROBES = {0x06020000, 0x06090011}  # a read of an absent object: a master probing, not a fault
# objects CiA 301 / CiA 402 make mandatory: a device without them fails a master's boot
MANDATORY = {(0x1000, 0): 'CiA 301', (0x1018, 0): 'CiA 301', (0x1018, 1): 'CiA 301', (0x6502, 0): 'CiA 402',
             (0x6040, 0): 'CiA 402', (0x6041, 0): 'CiA 402', (0x6060, 0): 'CiA 402', (0x6061, 0): 'CiA 402'}
TIMEOUT = 0x05040000


@dataclass(slots=True)
class SdoTransaction:
    node: int
    index: int
    subindex: int
    write: bool
    t_request: float
    t_response: float | None = None
    data: bytearray = field(default_factory=bytearray)
    abort: int | None = None
    segmented: bool = False
    block: bool = False
    phase: str = ''  # block transfer: init, init-resp, data, last, end, end-sent, end-resp
    status: str = 'open'  # ok / abort / no response / open
    last_segment: bool = False  # download: the client sent its last segment
    answered: bool = False  # the server's frame to the client's last one came
    invalid: int = 0  # server frames that fit no request of it (a burst of garbage)
    by_client: bool = False  # the master aborted it
    seq: int = 0  # order among NMT / SDO / error-control events (Context.events)
    syncs: int = 0  # SYNC frames before its request

    @property
    def latency(self) -> float | None:
        return None if self.t_response is None else self.t_response - self.t_request

    @property
    def value(self) -> int | None:
        return int.from_bytes(self.data, 'little') if 0 < len(self.data) <= 8 else None


def _u32(data: bytes | bytearray, start: int) -> int:
    return int.from_bytes(data[start:start + 4].ljust(4, b'\0'), 'little')


class SdoLog:
    """Pairs the frames of each node's SDO channel into transactions."""

    def __init__(self, ctx: Context, on_done: Callable[[SdoTransaction], None]) -> None:
        self.ctx = ctx
        self.on_done = on_done
        self.transactions: list[SdoTransaction] = []
        self._open: dict[int, SdoTransaction] = {}
        self.unpaired_responses = 0
        self.invalid: dict[int, list[tuple[float, SdoTransaction | None, int]]] = {}  # node -> bursts
        self._last: dict[int, SdoTransaction] = {}  # node -> last transaction (closed or not)

    # -- frames ----------------------------------------------------------------------------
    def request(self, t: float, cob: int, data: bytes | bytearray) -> None:
        if not data:
            return
        node = cob - 0x600
        b0 = data[0]
        ccs = b0 >> 5
        txn = self._open.get(node)
        if txn is not None and txn.phase and b0 != 0x80 and self._block_request(txn, t, data):
            return
        if ccs in (1, 2, 5, 6):  # initiate download / upload / block upload / block download
            if txn is not None:
                self._close(txn, 'no response')
            if len(data) < 4:
                return
            txn = SdoTransaction(node, data[1] | data[2] << 8, data[3], ccs in (1, 6), t)
            ctx = self.ctx
            ctx.events += 1
            txn.seq, txn.syncs = ctx.events, ctx.syncs
            if ccs in (5, 6):
                txn.block, txn.phase = True, 'init'
            if ccs == 1 and b0 & 0x02:
                n = (b0 >> 2) & 3 if b0 & 0x01 else 0
                txn.data += data[4:8 - n]
                txn.last_segment = True
            elif ccs == 1:
                txn.segmented = True
            self._open[node] = txn
            self._last[node] = txn
            self.transactions.append(txn)
        elif ccs == 0 and txn is not None and txn.write:  # download segment
            n = (b0 >> 1) & 7
            txn.data += data[1:8 - n]
            txn.last_segment = bool(b0 & 0x01)
            txn.answered = False
        elif ccs == 3 and txn is not None and not txn.write:  # upload segment request
            txn.answered = False
        elif ccs == 4 and len(data) >= 8:  # client abort
            if txn is None:
                txn = SdoTransaction(node, data[1] | data[2] << 8, data[3], False, t)
                self.transactions.append(txn)
                self._last[node] = txn
            txn.abort = _u32(data, 4)
            txn.t_response = t
            txn.by_client = True
            self._close(txn, 'abort', by_client=True)

    def response(self, t: float, cob: int, data: bytes | bytearray) -> None:
        if not data:
            return
        node = cob - 0x580
        txn = self._open.get(node)
        b0 = data[0]
        scs = b0 >> 5
        if txn is None:
            if scs == 4 and len(data) >= 8:
                self._server_abort_after(t, node, data)
                return
            self.unpaired_responses += 1
            last = self._last.get(node)
            if last is not None and last.status == 'abort' and last.by_client and not _answers(last, data):
                self._invalid(t, node, last)  # more garbage after the master gave up (a late answer is none)
            return
        if txn.block and b0 != 0x80:  # sub-block segments (0x81..0xFF with the last) are no abort
            txn.t_response = t
            self._block_response(txn, data)
            return
        if scs != 4 and (txn.answered or not self._fits(txn, scs)):
            if not (txn.answered and _answers(txn, data)):  # a repeated well-formed answer is no garbage
                self._invalid(t, node, txn)
            return
        txn.t_response = t
        txn.answered = True
        if scs == 4:
            txn.abort = _u32(data, 4)
            self._close(txn, 'abort')
        elif scs == 3 or scs == 1:  # initiate download response
            if txn.last_segment:
                self._close(txn, 'ok')
        elif scs == 2:  # initiate upload response
            if b0 & 0x02:
                n = (b0 >> 2) & 3 if b0 & 0x01 else 0
                txn.data += data[4:8 - n]
                self._close(txn, 'ok')
            else:
                txn.segmented = True
        elif scs == 0 and txn.segmented and not txn.write:  # upload segment
            n = (b0 >> 1) & 7
            txn.data += data[1:8 - n]
            if b0 & 0x01:
                self._close(txn, 'ok')

    @staticmethod
    def _fits(txn: SdoTransaction, scs: int) -> bool:
        """Is a server command specifier the answer to the client's last frame of ``txn``?"""
        if txn.write:  # initiate download response, then download segment responses
            return scs == 3 if txn.t_response is None else scs == 1
        return scs == 2 if txn.t_response is None else scs == 0  # initiate upload response, then segments

    def _invalid(self, t: float, node: int, txn: SdoTransaction | None) -> None:
        """A server frame that answers nothing: counted into the burst it belongs to."""
        if txn is not None:
            txn.invalid += 1
        bursts = self.invalid.setdefault(node, [])
        if bursts and bursts[-1][1] is txn:
            start, _txn, count = bursts[-1]
            bursts[-1] = (start, txn, count + 1)
        else:
            bursts.append((t, txn, 1))

    def _server_abort_after(self, t: float, node: int, data: bytes | bytearray) -> None:
        """A server abort with no transfer open (the master had aborted it already): kept, not dropped."""
        index, subindex, code = data[1] | data[2] << 8, data[3], _u32(data, 4)
        last = self._last.get(node)
        write = last.write if last is not None and (last.index, last.subindex) == (index, subindex) else False
        txn = SdoTransaction(node, index, subindex, write, t, t_response=t, abort=code)
        if last is not None and (last.index, last.subindex) == (index, subindex):
            txn.t_request = last.t_request
            txn.data = last.data
        self.transactions.append(txn)
        self._last[node] = txn
        self._close(txn, 'abort', late=True)

    # -- block transfers (CiA 301 §7.2.4.3.9-16): sub-block segments carry a sequence number --
    def _block_request(self, txn: SdoTransaction, t: float, data: bytes | bytearray) -> bool:
        """A client frame of an open block transfer; False: not part of it (a new request)."""
        b0, phase = data[0], txn.phase
        if txn.write:
            if phase == 'data':
                txn.data += data[1:8]
                if b0 & 0x80:
                    txn.phase = 'last'
                return True
            if phase == 'end' and b0 & 0xE3 == 0xC1:
                _trim(txn, (b0 >> 2) & 7)
                txn.phase = 'end-sent'
                return True
            return False
        if phase == 'init-resp' and b0 == 0xA3:  # start upload
            txn.phase = 'data'
            return True
        if phase in ('data', 'last') and b0 & 0xE3 == 0xA2:  # block acknowledged
            txn.phase = 'end' if phase == 'last' else 'data'
            return True
        if phase == 'end-resp' and b0 & 0xE3 == 0xA1:  # end confirmed
            txn.t_response = t
            self._close(txn, 'ok')
            return True
        return False

    def _block_response(self, txn: SdoTransaction, data: bytes | bytearray) -> None:
        b0, phase = data[0], txn.phase
        if txn.write:
            if phase == 'init' and b0 & 0xE3 == 0xA0:
                txn.phase = 'data'
            elif phase in ('data', 'last') and b0 & 0xE3 == 0xA2:
                txn.phase = 'end' if phase == 'last' else 'data'
            elif phase == 'end-sent' and b0 & 0xE3 == 0xA1:
                self._close(txn, 'ok')
        elif phase == 'init' and b0 & 0xE1 == 0xC0:
            txn.phase = 'init-resp'
        elif phase == 'data':
            txn.data += data[1:8]
            if b0 & 0x80:
                txn.phase = 'last'
        elif phase == 'end' and b0 & 0xE3 == 0xC1:
            _trim(txn, (b0 >> 2) & 7)
            txn.phase = 'end-resp'

    # -- results ---------------------------------------------------------------------------
    def _close(self, txn: SdoTransaction, status: str, by_client: bool = False, late: bool = False) -> None:
        txn.status = status
        if self._open.get(txn.node) is txn:
            del self._open[txn.node]
        if status == 'ok':
            self.on_done(txn)
            return
        ctx = self.ctx
        label = ctx_label(ctx, txn)  # for the finding only: most transactions are ok
        access = 'write' if txn.write else 'read'
        if status == 'abort' and txn.abort is not None:
            code = txn.abort
            who = ('the master aborted' if by_client else
                   'aborted, after the master had given up,' if late else 'aborted')
            value = f' of {format_value(txn)}' if txn.write and txn.data else ''
            mandatory = MANDATORY.get((txn.index, txn.subindex))
            cause = abort_cause(code)
            if by_client and code == TIMEOUT and txn.invalid:
                cause = (f'the server did answer, with {txn.invalid} invalid frame(s) that fit no request: '
                         'its SDO server (firmware) is broken, or two nodes share its COB-ID')
            if mandatory and not txn.write and code in _PROBES:
                severity = Severity.ERROR if mandatory == 'CiA 402' else Severity.WARNING
                cause = (f'{label} is mandatory ({mandatory}): a master that reads it at boot (lely, ros2_canopen) '
                         'stops configuring the node (a wrong node id, a device other than the config says, or a '
                         'firmware without it)')
            else:
                severity = Severity.ERROR if txn.write else Severity.INFO if code in _PROBES else Severity.WARNING
            ctx.add(severity, txn.t_request, txn.node, f'SDO {label} {access}{value} {who} 0x{code:08X} '
                    f'({abort_text(code)})', cause, 'sdo-abort', slot=axis_slot(txn.index),
                    short=f'node {txn.node} lacks mandatory {label}'
                    if mandatory and not txn.write and code in _PROBES else
                    f'SDO {access} of {label} on node {txn.node} aborted 0x{code:08X}')
        elif status == 'no response':
            ctx.add(Severity.WARNING, txn.t_request, txn.node, f'SDO {label} {access} got no response',
                    'the node is off the bus, not in a state that serves SDO, or another request overtook it',
                    'sdo-timeout', slot=axis_slot(txn.index))

    def finish(self, end: float) -> None:
        for txn in list(self._open.values()):
            if self.ctx.timing and end - txn.t_request >= NO_ANSWER_S:
                self._close(txn, 'no response')
        for node, bursts in sorted(self.invalid.items()):
            for start, burst_txn, count in bursts:
                during = '' if burst_txn is None else \
                    f' during the {"download" if burst_txn.write else "upload"} of {ctx_label(self.ctx, burst_txn)}'
                self.ctx.add(Severity.ERROR, start, node,
                             f'SDO server sent {count} invalid frame(s) on 0x{0x580 + node:03X}{during}: '
                             'responses that fit no request (a burst)',
                             'the node\'s SDO server (firmware) is broken, or another node sends on its COB-ID',
                             'sdo-invalid', short=f'SDO server of node {node} sent invalid frames')


def _answers(txn: SdoTransaction, data: bytes | bytearray) -> bool:
    """Is a server frame a well-formed initiate response naming the transaction's object?"""
    return len(data) >= 4 and data[0] >> 5 in (2, 3) and (data[1] | data[2] << 8, data[3]) == (txn.index, txn.subindex)


def _trim(txn: SdoTransaction, unused: int) -> None:
    """The last segment's ``unused`` bytes carry no data (from the end frame)."""
    if unused:
        del txn.data[-unused:]


def axis_slot(index: int) -> int | None:
    """The axis slot of a CiA 402 object (0x6000 + 0x800 per slot); None: the node's own."""
    return (index - 0x6000) // 0x800 if 0x6000 <= index < 0xA000 else None


def ctx_label(ctx: Context, txn: SdoTransaction) -> str:
    info = ctx.nodes.get(txn.node)
    name = object_name(info.od if info else None, txn.index, txn.subindex)
    sub = f':{txn.subindex}' if txn.subindex else ''
    return f'0x{txn.index:04X}{sub}' + (f' ({name})' if name else '')


def format_value(txn: SdoTransaction) -> str:
    value = txn.value
    if value is not None and len(txn.data) <= 4:
        return f'0x{value:0{2 * len(txn.data)}X} ({value})'
    text = bytes(txn.data)
    if text and all(32 <= c < 127 for c in text.rstrip(b'\0')):
        return repr(text.rstrip(b'\0').decode('ascii'))
    return text.hex(' ')
