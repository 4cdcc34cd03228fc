"""The simulated SINAMICS S120 Control Unit with its CBC10 as one CANopen node:
:class:`SimS120`, registered as the ``sinamics_s120`` simulator (what it reproduces: the
package docstring)."""
from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

from drive_bridge.cia402.statemachine import State
from drive_bridge.model import NodeConfig
from drive_bridge.sim.commobjects import PRODUCER_HEARTBEAT
from drive_bridge.sim.drive402 import SimDrive402
from drive_bridge.sim.nmt import NmtState
from drive_bridge.sim.nodeid import change_node_id
from drive_bridge.sim.pdocodec import Pdo
from drive_bridge.sim.registry import register_simulator
from drive_bridge.sim.s120.address import AddressSwitch
from drive_bridge.sim.s120.axis import S120Axis
from drive_bridge.sim.s120.dictionary import (
    invalid_cob_ids,
    predefined_connection_set,
    relax_inverted_limits,
)
from drive_bridge.sim.s120.emcy import Message, S120Emcy
from drive_bridge.sim.s120.messages import ActiveMessages
from drive_bridge.sim.s120.objects import (
    A08751,
    A08758,
    COMMUNICATION_ERROR_VALUE,
    CONSUMER_HEARTBEAT,
    CU,
    ERROR_HISTORY,
    F08700,
    P8641_REACTIONS,
    PDO_BLOCK,
    REACTIONS,
)
from drive_bridge.sim.s120.options import S120_OPTIONS, check_options, drive_object_count
from drive_bridge.sim.s120.parameters import ParameterSet
from drive_bridge.sim.s120.pdo import S120PdoEngine
from drive_bridge.sim.s120.storage import ParameterStorage
from drive_bridge.sim.s120.telegram import TelegramMonitor
from drive_bridge.sim.s120.view import DriveObjectView, drive_object_view
from drive_bridge.sim.s120.window import ParameterWindow
from drive_bridge.sim.store import key


@register_simulator('sinamics_s120')
class SimS120(SimDrive402):
    """A simulated SINAMICS S120 CU320-2 with CBC10; see the package docstring."""

    OPTIONS = S120_OPTIONS
    PDO_ENGINE = S120PdoEngine
    EMCY_PRODUCER = S120Emcy
    AXIS_CLASS = S120Axis

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        given = dict(options or {})
        self._dos = drive_object_count(node.name, given.get('drive_objects', 0), SimDrive402.axis_count(node))
        self._kept: list[Message] = []
        self._load_saved = False
        self.window = ParameterWindow(self)
        self.telegrams = TelegramMonitor()
        super().__init__(node, options=given)
        self.s120_axes: tuple[S120Axis, ...] = tuple(a for a in self.axes if isinstance(a, S120Axis))
        check_options(self.name, self.options, self.s120_axes)
        opts = self.options
        self.cu = ParameterSet(True, {9: 0, 8620: self.node_id, 8684: opts['p8684'], 8848: float(opts['p8848']),
                                      8743: [a.do_number for a in self.s120_axes]
                                      + [0] * (8 - len(self.s120_axes))})
        self.effective_p8848 = float(opts['p8848'])
        self.address_switch = AddressSwitch(opts['address_switch'])
        self._power_cycle = False
        self.store.remove(CONSUMER_HEARTBEAT)  # producer only [2.2]
        relax_inverted_limits(self.store)
        emcy: S120Emcy = self.emcy  # type: ignore[assignment]
        self.active = ActiveMessages(self.store, self.s120_axes, emcy, self.set_nmt_state, self.pdo.poll_events)
        emcy.messages = lambda: self.messages
        pdo: S120PdoEngine = self.pdo  # type: ignore[assignment]
        pdo.sub0_read_only = opts['mapping_sub0_read_only']
        pdo.on_limit = self._rpdo_limit
        pdo.on_received = self._telegram
        for axis in self.s120_axes:
            axis.on_acknowledged = self._acknowledged
        if opts['predefined_mapping']:
            predefined_connection_set(self.store, len(self.axes))
        invalid_cob_ids(self.store, len(self.axes))
        self.window.add_objects(self.register_object)
        self.storage = ParameterStorage(self.store, self.cu, self.s120_axes, self.reload_communication_objects)
        self._register_s120_objects()
        self.storage.keep_factory()
        self.active.write_history()

    # -- construction ------------------------------------------------------------------------------------
    def axis_count(self, node: NodeConfig) -> int:  # type: ignore[override]  # needs the option
        return self._dos

    def _register_s120_objects(self) -> None:
        store = self.store

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if key(index, subindex) in store:
                self.register_object(index, subindex, **hooks)

        reg(ERROR_HISTORY, 0, on_write=lambda value: self.acknowledge_all())
        self.storage.register(reg)

    # -- drive objects -----------------------------------------------------------------------------------
    @property
    def drive_objects(self) -> tuple[int, ...]:
        """The motor drive objects' numbers by axis slot (p8743)."""
        return tuple(a.do_number for a in self.s120_axes)

    def axis_of(self, do: int) -> S120Axis | None:
        for axis in self.s120_axes:
            if axis.do_number == do:
                return axis
        return None

    def drive_object(self, do: int) -> int:
        """A drive-object number (0: the first axis'), checked."""
        number = self.s120_axes[0].do_number if do == 0 else do
        if number != CU and self.axis_of(number) is None:
            raise ValueError(f'node {self.name!r} has no drive object {do}: Control Unit 1, motors '
                             f'{", ".join(map(str, self.drive_objects))}')
        return number

    def _slot_do(self, number: int) -> int:
        """The drive object whose PDO block holds PDO ``number``."""
        slot = (number - 1) // PDO_BLOCK
        return self.s120_axes[slot].do_number if slot < len(self.s120_axes) else CU

    # -- the parameter window (p8630: window.py) --------------------------------------------------------
    @property
    def selector(self) -> list[int]:
        """p8630: drive object, page, thousands range."""
        return self.window.selector

    def parameter(self, do: int, number: int, index: int = 0) -> Any:
        """Parameter ``number`` [``index``] of drive object ``do`` (1: the Control Unit) now."""
        with self.lock:
            return self.window.parameter(do, number, index)

    def saved_parameter(self, do: int, number: int, index: int = 0) -> Any:
        """What the memory card holds for the parameter (loaded at power-on and reboot)."""
        with self.lock:
            axis = self.axis_of(self.drive_object(do))
            return (self.cu if axis is None else axis.parameters).saved[number][index]

    def schedule_reboot(self) -> None:
        """p0009 went back to 0: the CU reboots by itself after ``reboot_delay`` s [2.10]."""
        self.timers.call_later(self.options['reboot_delay'], self._reboot)

    def _reboot(self) -> None:
        with self.lock:
            if not self.powered:
                return
            self._load_saved = True
            self.restart(application=True)

    # -- messages (messages.py) -------------------------------------------------------------------------
    @property
    def messages(self) -> list[Message]:
        """The active faults and alarms in order of occurrence."""
        return self.active.items

    def _acknowledged(self, axis: S120Axis) -> None:
        """The axis left Fault (controlword bit 7 edge, or 0x1003:0 = 0): its faults are gone."""
        self.active.remove(lambda m: m.fault and m.do == axis.do_number and not m.persistent)

    def fault_cause_persists(self, axis: Any) -> bool:
        do = getattr(axis, 'do_number', None)
        return any(m.fault and m.persistent and m.do == do for m in self.messages)

    def acknowledge_all(self) -> None:
        """0x1003:0 = 0: acknowledge the faults of every drive object of the CU [6.3]."""
        for axis in self.s120_axes:
            axis.acknowledge_fault()
        busy = {a.do_number for a in self.s120_axes if a.state in (State.FAULT, State.FAULT_REACTION_ACTIVE)}
        self.active.remove(lambda m: m.fault and not m.persistent and m.do not in busy)
        self.active.write_history()

    # -- fault injection (tests) ---------------------------------------------------------------------------
    def inject_fault(self, number: int, do: int = 0, manufacturer: bytes = b'', persistent: bool = False, *,
                     value: int = 0, reaction: str = 'OFF2') -> None:
        """Fault F``number`` on drive object ``do`` (0: the first axis; 1: the Control Unit): EMCY,
        0x1001 / 0x1003, r0947 / r0949, the drive object's ``reaction`` ('OFF1', 'OFF2', 'OFF3')
        and Fault, p8609[1]. ``persistent``: it cannot be acknowledged before :meth:`clear_cause`.
        (``manufacturer`` is ignored: the S120 fills bytes 3..7 itself.)"""
        if reaction not in REACTIONS:
            raise ValueError(f'fault reaction {reaction!r}: one of {", ".join(REACTIONS)}')
        with self.lock:
            self.active.add(Message(number, self.drive_object(do), True, value, persistent, reaction))

    def inject_alarm(self, number: int, do: int = 0, *, value: int = 0) -> None:
        """Alarm A``number`` on drive object ``do`` until :meth:`clear_cause`: statusword bit 7; in the
        CAN range 8700..8799 also EMCY, 0x1001 and 0x1003."""
        with self.lock:
            self.active.add(Message(number, self.drive_object(do), False, value, True))

    def clear_cause(self, number: int | None = None, do: int | None = None) -> None:
        """The cause of the matching messages is gone: alarms disappear, faults can be acknowledged."""
        with self.lock:
            target = None if do is None else self.drive_object(do)

            def match(m: Message) -> bool:
                return (number is None or m.number == number) and (target is None or m.do == target)

            for m in self.messages:
                if match(m):
                    m.persistent = False
            self.active.remove(lambda m: match(m) and not m.fault)

    def clear_fault_cause(self, axis: int | None = None) -> None:
        with self.lock:
            for ax in self.s120_axes if axis is None else (self.s120_axes[axis],):
                for m in self.messages:
                    if m.fault and m.do == ax.do_number:
                        m.persistent = False

    # -- supervision: life guarding, heartbeat, telegram monitoring, the RPDO limit ------------------------
    def _heartbeat_on(self) -> bool:
        return bool(self.store.values.get(key(PRODUCER_HEARTBEAT, 0), 0))

    def answers_guarding(self) -> bool:
        return not self._heartbeat_on()  # heartbeat and guarding exclude each other [2.2]

    def life_time_limit(self) -> float:
        return 0.0 if self._heartbeat_on() else math.inf

    def on_life_guarding_lost(self) -> None:
        """F08700 value 2 on every drive object: a fault with the reaction of its p8641 (1 OFF1, 2 OFF2,
        3 OFF3), an alarm where p8641 = 0; then p8609[0]."""
        for axis in self.s120_axes:
            reaction = P8641_REACTIONS.get(int(axis.parameter(8641)))
            self.active.add(Message(F08700, axis.do_number, reaction is not None, COMMUNICATION_ERROR_VALUE, True,
                                reaction or 'OFF2'))
        self.active.nmt_reaction(1)

    def on_life_guarding_recovered(self) -> None:
        for m in self.messages:
            if m.number == F08700 and m.value == COMMUNICATION_ERROR_VALUE:
                m.persistent = False
        self.active.remove(lambda m: m.number == F08700 and not m.fault)

    def on_heartbeat_lost(self, node: int) -> None:
        """The S120 consumes no heartbeat [2.2]."""

    def _rpdo_limit(self, exceeded: bool) -> None:
        if exceeded:
            self.active.add(Message(A08758, CU, False, 0, True))
        else:
            self.active.remove(lambda m: m.number == A08758)

    def _telegram(self, pdo: Pdo, stamp: float) -> None:
        """An RPDO arrived: A08751 while its mean cycle is below 2 x p8848 [2.4, §2.10]."""
        do = self._slot_do(pdo.number)
        too_fast = self.telegrams.received(pdo.number, stamp, 2.0 * self.effective_p8848 / 1000.0)
        if too_fast:
            self.active.add(Message(A08751, do, False, 0, True))
        elif too_fast is False:
            self._telegram_check(do, stamp)

    def _telegram_check(self, do: int, now: float) -> bool:
        """A08751 of ``do`` goes once none of its RPDOs comes too fast (or they stopped)."""
        if not any(m.number == A08751 and m.do == do for m in self.messages):
            return False
        if not self.telegrams.in_spec(lambda number: self._slot_do(number) == do, now,
                                      2.0 * self.effective_p8848 / 1000.0):
            return False
        return self.active.remove(lambda m: m.number == A08751 and m.do == do)

    def supervise(self, now: float) -> bool:
        stamp = time.time()  # the frames' time base
        changed = False
        if self._heartbeat_on() and any(m.number == F08700 and m.persistent for m in self.messages):
            self.on_life_guarding_recovered()  # heartbeat now: life guarding is off, its event over
            changed = True
        for axis in self.s120_axes:
            changed = self._telegram_check(axis.do_number, stamp) or changed
        return changed

    # -- life cycle --------------------------------------------------------------------------------------
    def power_on(self) -> None:
        with self.lock:
            if not self.powered:
                self._load_saved = self._power_cycle = True
            super().power_on()

    def set_address_switch(self, value: int) -> None:
        """Turn the Control Unit's address switch (0..255): read at the next POWER ON (module address)."""
        with self.lock:
            self.address_switch.set(value)

    def _read_node_id(self) -> None:
        """At POWER ON: the address switch, else the saved p8620 (module address)."""
        node_id, shown = self.address_switch.node_id(self.cu.get(8620))
        if shown:
            self.cu.set(8620, 0, node_id)
        change_node_id(self, node_id, self.storage.factory)

    def reset_application(self) -> None:
        """Power-on and CU reboot load the saved parameters; NMT reset node keeps them (they are the
        drive's, not CANopen objects). Messages go, those with a persisting cause come back at boot."""
        if self._load_saved:
            self._load_saved = False
            self.cu.load_saved()
            for axis in self.s120_axes:
                axis.parameters.load_saved()
            self.window.selector[:] = [0, 0, 0]
            if self._power_cycle or self.options['node_id_at_reboot']:
                self._read_node_id()
        self._power_cycle = False
        self.effective_p8848 = float(self.cu.get(8848))
        self._kept = [m for m in self.messages if m.persistent and m.number != F08700]
        self.active.items = []
        self.telegrams.clear()
        self.active.changed()
        super().reset_application()

    def on_reset_communication(self) -> None:
        """0x1003 went back to its stored value with 0x1000..0x1FFF: it lists the messages still active."""
        self.active.write_history()

    def on_boot(self) -> None:
        super().on_boot()
        state = self.cu.get(8684)
        if state == 5:
            self.set_nmt_state(NmtState.OPERATIONAL)
        elif state == 4:
            self.set_nmt_state(NmtState.STOPPED)
        kept, self._kept = self._kept, []
        for message in kept:
            self.active.add(message)

    # -- inspection (tests) -----------------------------------------------------------------------------
    def view(self, do: int = 0) -> DriveObjectView:
        """A snapshot of drive object ``do`` (0: the first axis; 1: the Control Unit)."""
        with self.lock:
            return drive_object_view(self, do)

    @property
    def views(self) -> tuple[DriveObjectView, ...]:
        return tuple(self.view(do) for do in (CU, *self.drive_objects))

    @property
    def active_messages(self) -> tuple[str, ...]:
        """'F07900@3', 'A08751@4', ... in order of occurrence."""
        with self.lock:
            return tuple(f'{m.label}@{m.do}' for m in self.messages)

    @property
    def valid_rpdos(self) -> int:
        with self.lock:
            return self.pdo.valid_rpdos  # type: ignore[attr-defined, no-any-return]
