"""CiA 402 over PDO without a config: which PDOs carry the controlword and the statusword,
inferred from the traffic, so a Fault and its recovery or a working enable are seen in a bare
log. A node is taken for a CiA 402 drive when its device type (0x1000) says so, when the
master accesses its CiA 402 objects by SDO, or when its RPDO's first word takes only
controlword commands while its TPDO's first word takes only statusword states. Until that is
decided, a node's PDO frames are held (a few) and then replayed in order."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from drive_bridge.bag.diagnose.model import Context
from drive_bridge.cia402.statemachine import State, state_from_statusword

MIN_FRAMES = 2  # frames of each kind before a node's words are judged
HOLD = 64  # frames held per node at most while undecided
_COMMANDS = frozenset({0x00, 0x02, 0x06, 0x07, 0x0E, 0x0F}) | frozenset(range(0x80, 0x90))

Configure = Callable[[int, str, int, int, tuple[tuple[int, int, int], ...], str], None]
Replay = Callable[[float, int, bytes | bytearray], None]


def is_controlword(word: int) -> bool:
    """A device control command (CiA 402 Table 7), bits 9-15 clear (bit 8: halt)."""
    return word & 0xFE00 == 0 and word & 0x8F in _COMMANDS


def is_statusword(word: int) -> bool:
    return state_from_statusword(word) is not State.UNKNOWN


@dataclass
class NodeWords:
    tpdo: dict[int, list[int]] = field(default_factory=dict)  # (TPDO cob) -> first words
    rpdo: dict[int, list[int]] = field(default_factory=dict)
    held: list[tuple[float, int, bytes | bytearray, int]] = field(default_factory=list)  # (t, cob, data, seq)
    profile402: bool = False  # device type or SDO access of CiA 402 objects says so
    done: bool = False


class Cia402Inference:
    def __init__(self, ctx: Context, configure: Configure, replay: Replay) -> None:
        self.ctx = ctx
        self.configure = configure
        self.replay = replay
        self.nodes: dict[int, NodeWords] = {}

    def hint(self, node: int) -> None:
        """The node is a CiA 402 drive (device type 0x...0192, or its 0x6040-0x67FF objects used by SDO)."""
        words = self.nodes.setdefault(node, NodeWords())
        words.profile402 = True

    def frame(self, t: float, cob: int, node: int, tpdo: bool, data: bytes | bytearray) -> bool:
        """A PDO frame of the predefined set without a known mapping; True: held (or decided and replayed)."""
        words = self.nodes.get(node)
        if words is None:
            words = self.nodes[node] = NodeWords()
        if words.done or len(data) < 2:
            return False
        table = words.tpdo if tpdo else words.rpdo
        table.setdefault(cob, []).append(data[0] | data[1] << 8)
        ctx = self.ctx
        words.held.append((t, cob, data, ctx.events))
        if self._decide(node, words):
            words.done = True
            held, words.held = words.held, []
            now = ctx.events
            for t_held, cob_held, data_held, seq in held:
                ctx.events = seq  # the state changes they show keep their place among the other events
                self.replay(t_held, cob_held, data_held)
            ctx.events = max(now, ctx.events)
        elif len(words.held) >= HOLD:
            words.done = True  # undecided: not a drive, or not like one; its frames count as they came
            words.held = []
        return True

    def _decide(self, node: int, words: NodeWords) -> bool:
        status = {cob: w for cob, w in words.tpdo.items() if all(map(is_statusword, w))}
        control = {cob: w for cob, w in words.rpdo.items() if all(map(is_controlword, w)) and any(w)}
        if not status or max(map(len, status.values())) < (1 if words.profile402 else MIN_FRAMES):
            return False
        if not words.profile402 and not (control and max(map(len, control.values())) >= MIN_FRAMES):
            return False
        for cob in status:
            self.configure(node, 'TPDO', (cob - 0x180 - node) // 0x100 + 1, cob, ((0x6041, 0, 16),),
                           'inferred from the traffic')
        for cob in control:
            self.configure(node, 'RPDO', (cob - 0x200 - node) // 0x100 + 1, cob, ((0x6040, 0, 16),),
                           'inferred from the traffic')
        return True
