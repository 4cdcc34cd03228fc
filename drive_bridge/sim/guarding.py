"""Node guarding and life guarding of a simulated slave (CiA 301 §7.2.8.3.2.1).

The master polls with remote frames (RTR) on 0x700 + node; the slave answers each with one
byte: bit 7 a toggle (0 in the first reply after boot-up or reset communication, then
alternating with every reply) and bits 0..6 its NMT state (4 stopped, 5 operational, 127
pre-operational). Life guarding is the slave watching the master in turn: active while guard
time 0x100C (ms) x life time factor 0x100D != 0, armed by the first RTR; a life time without
an RTR is a life guarding event, answered by the slave's reaction hook.

RTR frames never reach canopen's subscribers (its listener drops remote frames), so one
:class:`RemoteFrames` listener per bus Notifier hands them to the slaves.
"""
from __future__ import annotations

import weakref
from collections.abc import Callable

import can
from canopen.objectdictionary import ODVariable, datatypes as dt

from drive_bridge.sim.store import ObjectStore, key

GUARD_TIME = 0x100C  # U16, ms
LIFE_TIME_FACTOR = 0x100D  # U8
EMCY_LIFE_GUARD = 0x8130  # "life guard error or heartbeat error"
TOGGLE = 0x80

Handler = Callable[[can.Message], None]


def _variable(name: str, index: int, data_type: int) -> ODVariable:
    var = ODVariable(name, index, 0)
    var.data_type = data_type
    var.access_type = 'rw'
    var.default = 0
    return var


def add_guarding_objects(store: ObjectStore) -> None:
    """0x100C and 0x100D for a device whose EDS lacks them (an EDS that has them wins)."""
    store.add(_variable('Guard time', GUARD_TIME, dt.UNSIGNED16))
    store.add(_variable('Life time factor', LIFE_TIME_FACTOR, dt.UNSIGNED8))


class NodeGuarding:
    """Toggle, reply count and life guarding of one slave (called with the slave's lock held)."""

    def __init__(self, store: ObjectStore, limit: Callable[[], float] | None = None) -> None:
        self._values = store.values
        self._limit = limit  # s: the device's own ceiling of the life time (None: none)
        self.reset()

    def reset(self) -> None:
        """Boot-up / reset communication: the next reply has toggle 0, life guarding waits for an RTR."""
        self._last_toggle: int | None = None
        self.last_request: float | None = None  # monotonic time of the last RTR (None: not armed)
        self.lost = False
        self.replies = 0

    @property
    def life_time(self) -> float:
        """s, guard time x life time factor (0: life guarding off), at most the device's limit."""
        values = self._values
        life = values.get(key(GUARD_TIME), 0) * values.get(key(LIFE_TIME_FACTOR), 0) / 1000.0
        return min(life, self._limit()) if life and self._limit is not None else life

    def reply(self, state: int, repeat_toggle: bool = False) -> bytes:
        """The answer to an RTR in NMT ``state``; ``repeat_toggle``: the last reply's toggle again
        (a fault injection)."""
        last = self._last_toggle
        toggle = 0 if last is None else (last if repeat_toggle else last ^ TOGGLE)
        self._last_toggle = toggle
        self.replies += 1
        return bytes([toggle | state & 0x7F])

    def request(self, now: float) -> bool:
        """An RTR arrived (answered or not): life guarding (re)armed. True if it had been lost."""
        self.last_request = now
        recovered, self.lost = self.lost, False
        return recovered

    def expired(self, now: float) -> bool:
        """True once per loss: life guarding active and armed, and no RTR for the life time."""
        if self.lost or self.last_request is None:
            return False
        life = self.life_time
        if not life or now - self.last_request <= life:
            return False
        self.lost = True
        return True


class RemoteFrames:
    """The one Notifier listener per bus that hands RTR frames to the slave owning the COB-ID."""

    _by_notifier: weakref.WeakKeyDictionary[can.Notifier, RemoteFrames] = weakref.WeakKeyDictionary()

    @classmethod
    def of(cls, notifier: can.Notifier) -> RemoteFrames:
        frames = cls._by_notifier.get(notifier)
        if frames is None:
            frames = cls._by_notifier[notifier] = cls(notifier)
        return frames

    def __init__(self, notifier: can.Notifier) -> None:
        self._notifier = notifier
        self._handlers: dict[int, Handler] = {}

    def add(self, cob_id: int, handler: Handler) -> None:
        if not self._handlers:
            self._notifier.add_listener(self._on_message)
        self._handlers[cob_id] = handler

    def remove(self, cob_id: int) -> None:
        if self._handlers.pop(cob_id, None) is not None and not self._handlers:
            try:
                self._notifier.remove_listener(self._on_message)
            except ValueError:
                pass

    def _on_message(self, msg: can.Message) -> None:
        if msg.is_remote_frame:
            handler = self._handlers.get(msg.arbitration_id)
            if handler is not None:
                handler(msg)
