"""The active SINAMICS messages of the simulated S120 [6]: a fault or alarm comes once per drive
object (again: its value and persistence change), a fault trips its drive object with the
message's reaction and, outside the CAN range, applies p8609[1]; a message that goes may end the
EMCY error state; every change rewrites 0x1003 and the drive objects' warning bits."""
from __future__ import annotations

from collections.abc import Callable, Sequence

from drive_bridge.sim.nmt import NmtState
from drive_bridge.sim.s120.axis import S120Axis
from drive_bridge.sim.s120.emcy import Message, S120Emcy, write_history
from drive_bridge.sim.s120.objects import ERROR_BEHAVIOUR, NMT_PRE_OPERATIONAL, NMT_STOPPED
from drive_bridge.sim.store import ObjectStore, key


class ActiveMessages:
    """``items``: the active messages in order of occurrence."""

    def __init__(self, store: ObjectStore, axes: Sequence[S120Axis], emcy: S120Emcy,
                 set_nmt_state: Callable[[NmtState], None], poll_events: Callable[[], None]) -> None:
        self._store = store
        self._axes = axes
        self._emcy = emcy
        self._set_nmt_state = set_nmt_state
        self._poll_events = poll_events
        self.items: list[Message] = []

    def add(self, message: Message) -> None:
        """``message`` occurs (an active one only takes its value and persistence)."""
        for m in self.items:
            if m.number == message.number and m.do == message.do and m.fault == message.fault:
                m.persistent, m.value = message.persistent, message.value
                return  # already active
        self.items.append(message)
        self.changed()
        if message.signalled:
            self._emcy.signal(message)
        if message.fault:
            for axis in self._axes:
                if axis.do_number == message.do:
                    axis.trip(message.reaction)
                    break
            if not message.can:
                self.nmt_reaction(2)  # p8609[1]: device errors
        self._poll_events()

    def remove(self, predicate: Callable[[Message], bool]) -> bool:
        """The messages ``predicate`` selects go; False if there was none."""
        removed = [m for m in self.items if predicate(m)]
        if not removed:
            return False
        self.items = [m for m in self.items if not predicate(m)]
        self.changed()
        if any(m.signalled for m in removed) and not self._emcy.register:
            self._emcy.all_clear()
        self._poll_events()
        return True

    def changed(self) -> None:
        self.write_history()
        for axis in self._axes:
            axis.warning = any(not m.fault and m.do == axis.do_number for m in self.items)

    def write_history(self) -> None:
        write_history(self._store, self.items, tuple(a.do_number for a in self._axes))

    def nmt_reaction(self, sub: int) -> None:
        """p8609[sub - 1] (0x1029:sub): 0 pre-operational, 1 no change, 2 stopped."""
        reaction = self._store.values.get(key(ERROR_BEHAVIOUR, sub), 1)
        if reaction == NMT_PRE_OPERATIONAL:
            self._set_nmt_state(NmtState.PRE_OPERATIONAL)
        elif reaction == NMT_STOPPED:
            self._set_nmt_state(NmtState.STOPPED)
