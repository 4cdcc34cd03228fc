"""The network boot as a whole (after the pass): a boot that stalls (NMT reset, maybe boot-ups
and an identity read, then only SYNC: no NMT start, nodes never configured), and a node that
boots late, linked to the master's SDO requests that timed out because it was not up yet.
Order comes from the events' sequence numbers, so a pasted log without time stamps works."""
from __future__ import annotations

from dataclasses import replace

from drive_bridge.bag.diagnose.model import Context, Severity
from drive_bridge.bag.diagnose.nmt import RESETS, NmtEvent, NmtTimeline
from drive_bridge.bag.diagnose.sdo import TIMEOUT, SdoLog, SdoTransaction, ctx_label

STALL_SYNCS = 10  # this many SYNC frames after the last configuration step, no NMT start: a stall
STALL_S = 0.1  # ... and (with time stamps) this long
START = 0x01


def _timed_out(txn: SdoTransaction) -> bool:
    return txn.status == 'no response' or (txn.by_client and txn.abort == TIMEOUT)


class BootAnalysis:
    def __init__(self, ctx: Context, nmt: NmtTimeline, sdo: SdoLog) -> None:
        self.ctx = ctx
        self.nmt = nmt
        self.sdo = sdo

    def finish(self, end: float) -> None:
        resets = [e for e in self.nmt.events if e.kind == 'command' and e.command in RESETS]
        if resets:
            self._late_boots(resets)
            self._stall(resets[-1], end)

    def _stall(self, reset: NmtEvent, end: float) -> None:
        ctx = self.ctx
        after = [e for e in self.nmt.events if e.seq > reset.seq]
        if any(e.kind == 'command' and e.command == START for e in after) or \
                any(e.kind == 'state' and e.text.endswith(' operational') for e in after):
            return
        sdo = [t for t in self.sdo.transactions if t.seq > reset.seq]
        boots = sorted({e.node for e in after if e.kind == 'boot-up' and e.node is not None})
        last_syncs, last_t = reset.syncs, reset.time + ctx.t0
        if sdo:
            last_syncs, last_t = sdo[-1].syncs, sdo[-1].t_request
        syncs = ctx.syncs - last_syncs
        if syncs < STALL_SYNCS or (ctx.timing and end - last_t < STALL_S):
            return
        span = f' ({end - last_t:.2f} s)' if ctx.timing else ''
        configured = sorted({t.node for t in sdo})
        if not boots:
            what = f'no node answered the {reset.text} with a boot-up'
            short = 'boot stalled: no node answered the NMT reset'
        elif sdo:
            objects = ', '.join(dict.fromkeys(ctx_label(ctx, t).split(' (')[0] for t in sdo if t.node == sdo[-1].node))
            what = (f'node(s) {", ".join(map(str, boots))} booted after the {reset.text}; the master read or wrote '
                    f'{objects} of node {sdo[-1].node}, then nothing more')
            short = f'boot stalled after the SDO to node {sdo[-1].node} (no NMT start)'
        else:
            what = f'node(s) {", ".join(map(str, boots))} booted after the {reset.text}, the master sent them nothing'
            short = 'boot stalled after the boot-ups (no NMT start)'
        idle = [n for n in boots if n not in configured]
        unconfigured = f'; node(s) {", ".join(map(str, idle))} never configured' if idle and sdo else ''
        ctx.add(Severity.ERROR, last_t, sdo[-1].node if sdo else None,
                f'boot stalled: {what}; {syncs} SYNC frame(s){span} follow with no NMT start{unconfigured}',
                'the master\'s boot of a node did not finish: a check failed (identity / device type against its '
                'config), it waits for a node that does not answer, or its boot timeout is too short; the master\'s '
                'log says which', 'boot-stall', short=short)

    def _late_boots(self, resets: list[NmtEvent]) -> None:
        ctx = self.ctx
        index = {id(f): i for i, f in enumerate(ctx.findings)}
        for boot in (e for e in self.nmt.events if e.kind == 'boot-up' and e.node is not None):
            reset = next((r for r in reversed(resets) if r.seq < boot.seq and r.node in (None, boot.node)), None)
            if reset is None:
                continue
            waited = [t for t in self.sdo.transactions
                      if t.node == boot.node and reset.seq < t.seq < boot.seq and _timed_out(t)]
            if not waited:
                continue
            late = f' {boot.time - reset.time:.3f} s after the {reset.text}' if ctx.timing else \
                f' after the {reset.text}'
            objects = ', '.join(dict.fromkeys(ctx_label(ctx, t) for t in waited))
            text = (f'booted{late}, after {len(waited)} SDO request(s) to it had timed out ({objects}): the '
                    'master talked to it before it was up')
            cause = ('its boot takes longer than the master waits: raise the master\'s boot timeout / SDO timeout, '
                     'or have it wait for the boot-up before the first SDO')
            ctx.add(Severity.WARNING, boot.time + ctx.t0, boot.node, text, cause, 'late-boot',
                    short=f'node {boot.node} booted late'
                    + (f' ({boot.time - reset.time:.1f} s)' if ctx.timing else ''))
            why = f'node {boot.node} had not booted yet (its boot-up came after this request)'
            starts = {round(t.t_request - ctx.t0, 9) for t in waited}
            for finding in list(ctx.findings):
                if finding.node == boot.node and finding.kind in ('sdo-abort', 'sdo-timeout') \
                        and round(finding.time, 9) in starts and id(finding) in index:
                    ctx.findings[index[id(finding)]] = replace(finding, cause=why)
