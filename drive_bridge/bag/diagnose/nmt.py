"""NMT and boot timeline per node: NMT commands (invalid ones too), boot-ups, and which
boot-ups the master commanded (NMT reset) and which were unexpected restarts."""
from __future__ import annotations

from dataclasses import dataclass

from drive_bridge.bag.diagnose.model import Context, Severity
from drive_bridge.cia301.nmt import NMT_COMMANDS as COMMANDS  # one table of the command names

RESETS = (0x81, 0x82)
STATES = {0x00: 'boot-up', 0x04: 'stopped', 0x05: 'operational', 0x7F: 'pre-operational'}
RESET_TO_BOOT_S = 10.0  # a boot-up this soon after an NMT reset is the reset's
_COMMANDED_STATE = {0x01: 0x05, 0x02: 0x04, 0x80: 0x7F}  # the state an NMT command puts a node in (resets: unknown)


@dataclass(frozen=True, slots=True)
class NmtEvent:
    time: float  # s since t0
    node: int | None  # None: the whole bus
    kind: str  # 'command', 'invalid command', 'boot-up', 'state'
    text: str
    seq: int = 0  # order among the NMT, SDO and error-control events (time stamps may be missing)
    syncs: int = 0  # SYNC frames before it
    command: int = 0  # the NMT command specifier of a command


class NmtTimeline:
    """NMT commands (COB-ID 0) and the boot-ups and state changes the error-control frames show."""

    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.events: list[NmtEvent] = []
        self.commands = 0
        self.invalid = 0
        self.boot_ups: dict[int, list[float]] = {}
        self.commanded_boots = 0
        self.unexpected_boots = 0
        self._resets: dict[int, float] = {}  # node (0 = all) -> time of the last reset command
        self._last_boot: dict[int, float] = {}
        self._commanded: dict[int, float] = {}  # node -> time of its last boot-up that answered a reset

    def _event(self, rel: float, node: int | None, kind: str, text: str, command: int = 0) -> None:
        ctx = self.ctx
        ctx.events += 1
        self.events.append(NmtEvent(rel, node, kind, text, ctx.events, ctx.syncs, command))

    def commanded_boot(self, node: int) -> float | None:
        """Absolute time of the node's last boot-up when it answered an NMT reset, else None."""
        boot = self._commanded.get(node)
        return boot if boot is not None and boot == self._last_boot.get(node) else None

    def command(self, t: float, cob: int, data: bytes | bytearray) -> None:
        self.commands += 1
        rel = t - self.ctx.t0
        if len(data) != 2 or data[0] not in COMMANDS:
            self.invalid += 1
            text = f'invalid NMT command {bytes(data).hex(" ") or "(no data)"}'
            node = data[1] if len(data) >= 2 and data[1] else None
            self._event(rel, node, 'invalid command', text)
            self.ctx.add(Severity.WARNING, t, node, text,
                         'a master or tool sent a frame on COB-ID 0 that is no NMT command '
                         '(command byte must be 01, 02, 80, 81 or 82, DLC 2)', 'nmt-invalid')
            return
        cmd, node = data[0], data[1]
        target = node or None
        state = _COMMANDED_STATE.get(cmd)
        states = self.ctx.states
        for n in ([node] if node else list(states)):
            if state is None:
                states.pop(n, None)
            else:
                states[n] = state
        self._event(rel, target, 'command', f'NMT {COMMANDS[cmd]} ({"all nodes" if not node else f"node {node}"})', cmd)
        if cmd in RESETS:
            self._resets[node] = t

    def state(self, t: float, node: int, text: str) -> None:
        self._event(t - self.ctx.t0, node, 'state', text)

    def boot_up(self, t: float, node: int, seen_before: bool, last_alive: float | None) -> None:
        """Classify a boot-up: commanded by an NMT reset, a power-on, or an unexpected restart.

        A boot-up long after a reset still answers it when the node stayed silent since the
        reset (``last_alive``: its last error-control frame before this one).
        """
        self.boot_ups.setdefault(node, []).append(t)
        reset = max(self._resets.get(node, -1e18), self._resets.get(0, -1e18))
        previous = self._last_boot.get(node, -1e18)
        self._last_boot[node] = t
        rel = t - self.ctx.t0
        silent_since_reset = last_alive is None or last_alive <= reset
        if reset > previous and (t - reset <= RESET_TO_BOOT_S or silent_since_reset):
            self.commanded_boots += 1
            self._commanded[node] = t
            self._event(rel, node, 'boot-up', f'boot-up {t - reset:.3f} s after the NMT reset'
                        if self.ctx.timing else 'boot-up after the NMT reset')
            if t - reset > RESET_TO_BOOT_S:
                self.ctx.add(Severity.WARNING, t, node,
                             f'boot-up {t - reset:.1f} s after the NMT reset, silent in between',
                             'a slow boot, or the drive was switched off and on again', 'late-boot')
        elif not seen_before:
            self._event(rel, node, 'boot-up', 'boot-up (first frame of the node: power-on)')
        else:
            self.unexpected_boots += 1
            self._event(rel, node, 'boot-up', 'boot-up without an NMT reset: unexpected restart')
            self.ctx.add(Severity.ERROR, t, node, 'boot-up without an NMT reset (unexpected restart)',
                         'the drive rebooted by itself: power loss, watchdog or an internal fault',
                         'unexpected-restart')

    def reset_between(self, node: int, start: float, end: float) -> bool:
        """Was this node reset by NMT between start and end (absolute times)?"""
        return any(start <= e.time + self.ctx.t0 <= end and e.kind == 'command' and 'reset' in e.text
                   and e.node in (node, None) for e in self.events)
