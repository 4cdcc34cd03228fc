"""The simulated SINAMICS S120 Control Unit with its CBC10 as one CANopen node:
:class:`SimS120`, registered as the ``sinamics_s120`` simulator (what it reproduces: the
package docstring)."""
from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from canopen.objectdictionary import ODVariable
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.statemachine import State
from drive_bridge.model import NodeConfig
from drive_bridge.sim.commobjects import PRODUCER_HEARTBEAT
from drive_bridge.sim.drive402 import SimDrive402
from drive_bridge.sim.nmt import NmtState
from drive_bridge.sim.nodeid import change_node_id
from drive_bridge.sim.pdocodec import COB_INVALID, Pdo
from drive_bridge.sim.registry import register_simulator
from drive_bridge.sim.s120.address import AddressSwitch
from drive_bridge.sim.s120.axis import S120Axis
from drive_bridge.sim.s120.emcy import Message, S120Emcy, write_history
from drive_bridge.sim.s120.objects import (
    A08751,
    A08758,
    ABORT_NO_SUBINDEX,
    ABORT_NOT_IN_OD,
    ABORT_NOT_STORED,
    ABORT_STATE,
    ABORT_TOO_HIGH,
    ABORT_TOO_LOW,
    ABORT_VALUE_RANGE,
    COMMUNICATION_ERROR_VALUE,
    CONSUMER_HEARTBEAT,
    CU,
    ERROR_BEHAVIOUR,
    ERROR_HISTORY,
    F08700,
    NMT_PRE_OPERATIONAL,
    NMT_STOPPED,
    P8641_REACTIONS,
    P8684_STATES,
    PAGE_SIZE,
    PARAMETER_BASE,
    PDO_BLOCK,
    RANGE_SIZE,
    REACTIONS,
    RESTORE_PARAMETERS,
    SIGNATURE_LOAD,
    SIGNATURE_SAVE,
    STORE_PARAMETERS,
)
from drive_bridge.sim.s120.options import S120_OPTIONS
from drive_bridge.sim.s120.parameters import DYNAMIC, PARAMETERS, Parameter, ParameterSet, profile_parameters
from drive_bridge.sim.s120.pdo import S120PdoEngine
from drive_bridge.sim.store import key

PDO_OFFSET = 0x40
P8630 = PARAMETER_BASE + 8630  # 0x41B6
TELEGRAM_SAMPLES = 8  # intervals averaged before A08751 can be raised
TELEGRAM_WEIGHT = 0.1  # of the newest interval in the running mean (a cycle, not one late frame)
TELEGRAM_JITTER = 0.97  # a cycle on average at 2 x p8848 is in spec: SYNC jitter does not raise A08751
TELEGRAM_HYSTERESIS = 1.05  # A08751 goes when the mean interval is this much above 2 x p8848
TELEGRAM_SILENCE = 1.0  # s without an RPDO: not cyclic any more (A08751 goes)

# the Predefined Connection Set of every drive object (Tab. 2-3, 2-4; + 0x800 per slot)
RPDO_MAPS = {1: (0x60400010,), 2: (0x60400010, 0x60FF0020), 3: (0x60400010, 0x60710010),
             4: (0x60400010, 0x60FF0020, 0x60710010)}
TPDO_MAPS = {1: (0x60410010,), 2: (0x60410010, 0x606C0020), 3: (0x60410010, 0x60770010),
             4: (0x60410010, 0x60630020)}



@dataclass(frozen=True)
class DriveObjectView:
    """What a test may see of one drive object (a snapshot)."""

    number: int
    slot: int | None  # axis slot; None for the Control Unit
    state: str  # CiA 402 state name ('' for the Control Unit)
    statusword: int
    mode: int  # 0x6061
    requested_mode: int  # 0x6060 as read back
    speed_rpm: float  # actual
    demand_rpm: float  # ramp-function generator output
    velocity: int  # 0x606C
    position: int  # 0x6063
    setpoint: float  # target of the running mode: 0x60FF (pv), 0x6042 (vl), 0x6071 (pt)
    torque: float  # actual, per mille of r0333
    faults: tuple[int, ...]
    alarms: tuple[int, ...]


class _Rate:
    """Mean interval of one RPDO's frames (exponential average)."""

    __slots__ = ('last', 'mean', 'samples')

    def __init__(self) -> None:
        self.last: float | None = None
        self.mean = math.inf
        self.samples = 0

    def update(self, stamp: float) -> None:
        if self.last is not None:
            interval = stamp - self.last
            if interval > TELEGRAM_SILENCE or interval < 0:
                self.mean, self.samples = math.inf, 0
            else:
                self.mean = interval if self.samples == 0 else \
                    (1 - TELEGRAM_WEIGHT) * self.mean + TELEGRAM_WEIGHT * interval
                self.samples += 1
        self.last = stamp


@register_simulator('sinamics_s120')
class SimS120(SimDrive402):
    """A simulated SINAMICS S120 CU320-2 with CBC10; see the package docstring."""

    OPTIONS = S120_OPTIONS
    PDO_ENGINE = S120PdoEngine
    EMCY_PRODUCER = S120Emcy
    AXIS_CLASS = S120Axis

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        given = dict(options or {})
        self._dos = self._drive_object_count(node, given.get('drive_objects', 0))
        self.messages: list[Message] = []
        self._kept: list[Message] = []
        self._load_saved = False
        self._full_save_done = False
        self.selector = [0, 0, 0]  # p8630
        self._monitors: dict[int, _Rate] = {}
        super().__init__(node, options=given)
        self.s120_axes: tuple[S120Axis, ...] = tuple(a for a in self.axes if isinstance(a, S120Axis))
        self._check_options()
        opts = self.options
        self.cu = ParameterSet(True, {9: 0, 8620: self.node_id, 8684: opts['p8684'], 8848: float(opts['p8848']),
                                      8743: [a.do_number for a in self.s120_axes]
                                      + [0] * (8 - len(self.s120_axes))})
        self.effective_p8848 = float(opts['p8848'])
        self.address_switch = AddressSwitch(opts['address_switch'])
        self._power_cycle = False
        self.store.remove(CONSUMER_HEARTBEAT)  # producer only [2.2]
        self._relax_inverted_limits()
        emcy: S120Emcy = self.emcy  # type: ignore[assignment]
        emcy.messages = lambda: self.messages
        pdo: S120PdoEngine = self.pdo  # type: ignore[assignment]
        pdo.sub0_read_only = opts['mapping_sub0_read_only']
        pdo.on_limit = self._rpdo_limit
        pdo.on_received = self._telegram
        for axis in self.s120_axes:
            axis.on_acknowledged = self._acknowledged
        if opts['predefined_mapping']:
            self._predefined_connection_set()
        self._invalid_cob_ids()
        self._add_parameter_window()
        self._register_s120_objects()
        self._factory = dict(self.store.defaults)
        self._write_history()

    # -- construction ------------------------------------------------------------------------------------
    @staticmethod
    def _drive_object_count(node: NodeConfig, requested: Any) -> int:
        available = SimDrive402._axis_count(node)
        if isinstance(requested, bool) or not isinstance(requested, int) or requested <= 0:
            return available  # (a wrong type or range is reported by the option check)
        if requested > available:
            raise ValueError(f'simulation option drive_objects of node {node.name!r}: {requested} drive objects, '
                             f'but the object dictionary has the objects of {available} axis slot(s) '
                             f'(0x6040 + 0x800 k)')
        return requested

    def _axis_count(self, node: NodeConfig) -> int:  # type: ignore[override]  # needs the option
        return self._dos

    def _check_options(self) -> None:
        where = f'simulation options of node {self.name!r}'
        numbers = [a.do_number for a in self.s120_axes]
        if len(set(numbers)) != len(numbers) or CU in numbers:
            raise ValueError(f'{where}: do_numbers {numbers} must differ from each other and from the Control '
                             f'Unit (1)')
        if self.options['p8684'] not in P8684_STATES:
            raise ValueError(f'{where}: p8684 must be 4 (stopped), 5 (operational) or 127 (pre-operational), '
                             f'got {self.options["p8684"]}')
        for axis in self.s120_axes:
            if not axis.supports(axis.boot_mode):
                raise ValueError(f'{where}: mode {axis.boot_mode} of slot {axis.slot}: the object dictionary '
                                 f'lacks its objects (vl needs 0x{obj.for_axis(0x6042, axis.slot):04X})')

    def _relax_inverted_limits(self) -> None:
        """Limits the EDS gives as unsigned hex for a signed object (the V4.8 file's 0x6871:
        0x0000..0xFFFF, read as 0..-1) mean the whole range: the drive takes every value."""
        store = self.store
        for k, var in list(store.variables.items()):
            if var.min is not None and var.max is not None and var.min > var.max:
                relaxed = copy.copy(var)
                relaxed.min = relaxed.max = None
                store.variables[k] = relaxed

    def _predefined_connection_set(self) -> None:
        store = self.store
        for slot in range(len(self.axes)):
            for base, maps in ((0x1600, RPDO_MAPS), (0x1A00, TPDO_MAPS)):
                for number, entries in maps.items():
                    index = base + PDO_OFFSET * slot + number - 1
                    subs = [key(index, s) for s in range(len(entries) + 1)]
                    if not all(k in store for k in subs) or any(
                            store.defaults.get(k) for k in store.keys_between(index, index)):
                        continue  # no such PDO, or the EDS maps it already
                    shifted = [e + ((obj.AXIS_OFFSET * slot) << 16) for e in entries]
                    if not all(key(e >> 16, e >> 8 & 0xFF) in store for e in shifted):
                        continue  # an object the EDS lacks (e.g. no 0x6077 in the flat file)
                    for sub, entry in enumerate(shifted, 1):
                        store.set_default(index, sub, entry)
                    store.set_default(index, 0, len(shifted))

    def _invalid_cob_ids(self) -> None:
        """Only the first drive object has predefined COB-IDs [1.4]: the others start invalid."""
        store = self.store
        for slot in range(1, len(self.axes)):
            for base in (0x1400, 0x1800):
                for number in range(8):
                    k = key(base + PDO_OFFSET * slot + number, 1)
                    if k in store and not store.defaults[k] & COB_INVALID:
                        store.set_default(base + PDO_OFFSET * slot + number, 1, store.defaults[k] | COB_INVALID)

    def _add_parameter_window(self) -> None:
        for number, parameter in PARAMETERS.items():
            index = PARAMETER_BASE + number
            for sub in range(parameter.size):
                var = ODVariable(f'{parameter.label} {parameter.name}', index, sub)
                var.data_type = parameter.data_type
                var.access_type = 'ro' if parameter.read_only else 'rw'
                self.store.add(var)  # (no default: 0 or 0.0 by type)
                self._register_window_object(index, sub)

    def _register_window_object(self, index: int, sub: int) -> None:
        def read() -> Any:
            return self._window_read(index, sub)

        def check(value: Any) -> None:
            self._window_check(index, sub, value)

        def write(value: Any) -> None:
            self._window_write(index, sub, value)

        self.register_object(index, sub, reader=read, validator=check, on_write=write)

    def _register_s120_objects(self) -> None:
        store = self.store

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if key(index, subindex) in store:
                self.register_object(index, subindex, **hooks)

        reg(ERROR_HISTORY, 0, on_write=lambda value: self.acknowledge_all())
        for sub in (1, 2, 3):
            reg(STORE_PARAMETERS, sub, reader=lambda: 1, validator=lambda v, s=sub: self._check_save(s, v),
                on_write=lambda v, s=sub: self._save(s))
            reg(RESTORE_PARAMETERS, sub, reader=lambda: 1, validator=self._check_restore,
                on_write=lambda v, s=sub: self._restore(s))

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

    def _do(self, do: int) -> int:
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

    # -- the parameter window (p8630) -----------------------------------------------------------------
    def _lookup(self, index: int, sub: int) -> tuple[int, Parameter, int]:
        """(drive object, parameter, parameter index) an access of (index, sub) reaches."""
        if index == P8630:
            return 0, PARAMETERS[8630], sub
        do, page, thousands = self.selector
        if do == 0:
            raise SdoAbortedError(ABORT_NOT_IN_OD)  # "no access to virtual objects"
        parameter = PARAMETERS.get(index - PARAMETER_BASE + RANGE_SIZE * thousands)
        if parameter is None or not parameter.on(do == CU) or parameter.scope == 'global':
            raise SdoAbortedError(ABORT_NOT_IN_OD)
        position = sub + PAGE_SIZE * page
        if position >= parameter.size:
            raise SdoAbortedError(ABORT_NO_SUBINDEX)
        return do, parameter, position

    def _window_read(self, index: int, sub: int) -> Any:
        do, parameter, position = self._lookup(index, sub)
        return self.parameter(do, parameter.number, position)

    def parameter(self, do: int, number: int, index: int = 0) -> Any:
        """Parameter ``number`` [``index``] of drive object ``do`` (1: the Control Unit) now."""
        with self._lock:
            if number == 8630:
                return self.selector[index]
            if number == 8609:
                return self.store.values.get(key(ERROR_BEHAVIOUR, index + 1), 1)
            do = self._do(do)
            if number in (947, 949, 2110):
                fault = number != 2110
                items = [m for m in self.messages if m.do == do and m.fault == fault][:8]
                if index >= len(items):
                    return 0
                return items[index].value if number == 949 else items[index].number
            axis = self.axis_of(do)
            if axis is None:
                return self.cu.get(number, index)
            if number in DYNAMIC:
                return axis.dynamic_parameter(number, index)
            return axis.parameter(number, index)

    def saved_parameter(self, do: int, number: int, index: int = 0) -> Any:
        """What the memory card holds for the parameter (loaded at power-on and reboot)."""
        with self._lock:
            axis = self.axis_of(self._do(do))
            return (self.cu if axis is None else axis.parameters).saved[number][index]

    def _window_check(self, index: int, sub: int, value: Any) -> None:
        do, parameter, position = self._lookup(index, sub)
        if parameter.number == 8630:
            allowed: tuple[int, ...] | range = ((0, CU, *self.drive_objects), range(4), range(6))[position]
            if value not in allowed:
                raise SdoAbortedError(ABORT_VALUE_RANGE)
            return
        if parameter.configuration and self.cu.get(9) != 3:
            raise SdoAbortedError(ABORT_STATE)  # only in device configuration (p0009 = 3) [2.10]
        if parameter.choices and value not in parameter.choices:
            raise SdoAbortedError(ABORT_VALUE_RANGE)
        if parameter.high is not None and value > parameter.high:
            raise SdoAbortedError(ABORT_TOO_HIGH)
        if parameter.low is not None and value < parameter.low:
            raise SdoAbortedError(ABORT_TOO_LOW)

    def _window_write(self, index: int, sub: int, value: Any) -> None:
        do, parameter, position = self._lookup(index, sub)
        number = parameter.number
        if number == 8630:
            self.selector[position] = int(value)
            return
        if number == 8609:
            self.store.values[key(ERROR_BEHAVIOUR, position + 1)] = int(value)
            return
        axis = self.axis_of(do)
        if axis is not None:
            axis.set_parameter(number, position, value)
            return
        old = self.cu.get(number, position)
        self.cu.set(number, position, value)
        if number == 9 and old != 0 and value == 0:  # the CU reboots by itself [2.10]
            self._timers.call_later(self.options['reboot_delay'], self._reboot)

    def _reboot(self) -> None:
        with self._lock:
            if not self.powered:
                return
            self._load_saved = True
            self.restart(application=True)

    # -- save and restore (0x1010 / 0x1011) [8.6] --------------------------------------------------------
    def _check_save(self, sub: int, value: int) -> None:
        if value != SIGNATURE_SAVE or (sub != 1 and not self._full_save_done):
            raise SdoAbortedError(ABORT_NOT_STORED)  # partial saves need a full save first

    @staticmethod
    def _check_restore(value: int) -> None:
        if value != SIGNATURE_LOAD:
            raise SdoAbortedError(ABORT_NOT_STORED)

    def _object_keys(self, sub: int) -> list[int]:
        """The stored objects a save / restore of ``sub`` covers (not process data, not computed)."""
        ranges = {1: ((0x1000, 0x1FFF), (0x6000, 0x9FFF)), 2: ((0x1000, 0x1FFF),), 3: ((0x6000, 0x9FFF),)}[sub]
        keys = []
        for low, high in ranges:
            for k in self.store.keys_between(low, high):
                var = self.store.variables[k]
                if (k >> 8) in (0x1001, ERROR_HISTORY, STORE_PARAMETERS, RESTORE_PARAMETERS) \
                        or k in self.store.readers or (var.pdo_mappable and var.writable):
                    continue
                keys.append(k)
        return keys

    def _save(self, sub: int) -> None:
        for k in self._object_keys(sub):
            self.store.defaults[k] = self.store.values[k]
        if sub == 1:
            self.cu.save()
            for axis in self.s120_axes:
                axis.parameters.save()
            self._full_save_done = True
        elif sub == 3:
            for axis in self.s120_axes:
                axis.parameters.save(profile_parameters())

    def _restore(self, sub: int) -> None:
        """Factory values at once (unlike CiA 301: not at the next reset) [8.6]."""
        for k in self._object_keys(sub):
            self.store.values[k] = self._factory[k]
        if sub == 1:
            self.cu.load_factory()
        for axis in self.s120_axes:
            if sub != 2:
                axis.parameters.load_factory(None if sub == 1 else profile_parameters())
            axis.invalidate_parameters()
        if sub != 3:
            self.reload_communication_objects()

    # -- messages --------------------------------------------------------------------------------------
    def _raise(self, message: Message) -> None:
        for m in self.messages:
            if m.number == message.number and m.do == message.do and m.fault == message.fault:
                m.persistent, m.value = message.persistent, message.value
                return  # already active
        self.messages.append(message)
        self._messages_changed()
        if message.signalled:
            self.emcy.signal(message)  # type: ignore[attr-defined]
        if message.fault:
            axis = self.axis_of(message.do)
            if axis is not None:
                axis.trip(message.reaction)
            if not message.can:
                self._nmt_reaction(2)  # p8609[1]: device errors
        self.pdo.poll_events()

    def _remove(self, predicate: Callable[[Message], bool]) -> bool:
        removed = [m for m in self.messages if predicate(m)]
        if not removed:
            return False
        self.messages = [m for m in self.messages if not predicate(m)]
        self._messages_changed()
        if any(m.signalled for m in removed) and not self.emcy.register:
            self.emcy.all_clear()  # type: ignore[attr-defined]
        self.pdo.poll_events()
        return True

    def _messages_changed(self) -> None:
        self._write_history()
        for axis in self.s120_axes:
            axis.warning = any(not m.fault and m.do == axis.do_number for m in self.messages)

    def _write_history(self) -> None:
        write_history(self.store, self.messages, self.drive_objects)

    def _nmt_reaction(self, sub: int) -> None:
        """p8609[sub - 1] (0x1029:sub): 0 pre-operational, 1 no change, 2 stopped."""
        reaction = self.store.values.get(key(ERROR_BEHAVIOUR, sub), 1)
        if reaction == NMT_PRE_OPERATIONAL:
            self.set_nmt_state(NmtState.PRE_OPERATIONAL)
        elif reaction == NMT_STOPPED:
            self.set_nmt_state(NmtState.STOPPED)

    def _acknowledged(self, axis: S120Axis) -> None:
        """The axis left Fault (controlword bit 7 edge, or 0x1003:0 = 0): its faults are gone."""
        self._remove(lambda m: m.fault and m.do == axis.do_number and not m.persistent)

    def fault_cause_persists(self, axis: Any) -> bool:
        do = getattr(axis, 'do_number', None)
        return any(m.fault and m.persistent and m.do == do for m in self.messages)

    def acknowledge_all(self) -> None:
        """0x1003:0 = 0: acknowledge the faults of every drive object of the CU [6.3]."""
        for axis in self.s120_axes:
            axis.acknowledge_fault()
        busy = {a.do_number for a in self.s120_axes if a.state in (State.FAULT, State.FAULT_REACTION_ACTIVE)}
        self._remove(lambda m: m.fault and not m.persistent and m.do not in busy)
        self._write_history()

    # -- fault injection (tests) ---------------------------------------------------------------------------
    def inject_fault(self, number: int, do: int = 0, manufacturer: bytes = b'', persistent: bool = False, *,
                     value: int = 0, reaction: str = 'OFF2') -> None:
        """Fault F``number`` on drive object ``do`` (0: the first axis; 1: the Control Unit): EMCY,
        0x1001 / 0x1003, r0947 / r0949, the drive object's ``reaction`` ('OFF1', 'OFF2', 'OFF3')
        and Fault, p8609[1]. ``persistent``: it cannot be acknowledged before :meth:`clear_cause`.
        (``manufacturer`` is ignored: the S120 fills bytes 3..7 itself.)"""
        if reaction not in REACTIONS:
            raise ValueError(f'fault reaction {reaction!r}: one of {", ".join(REACTIONS)}')
        with self._lock:
            self._raise(Message(number, self._do(do), True, value, persistent, reaction))

    def inject_alarm(self, number: int, do: int = 0, *, value: int = 0) -> None:
        """Alarm A``number`` on drive object ``do`` until :meth:`clear_cause`: statusword bit 7; in the
        CAN range 8700..8799 also EMCY, 0x1001 and 0x1003."""
        with self._lock:
            self._raise(Message(number, self._do(do), False, value, True))

    def clear_cause(self, number: int | None = None, do: int | None = None) -> None:
        """The cause of the matching messages is gone: alarms disappear, faults can be acknowledged."""
        with self._lock:
            target = None if do is None else self._do(do)

            def match(m: Message) -> bool:
                return (number is None or m.number == number) and (target is None or m.do == target)

            for m in self.messages:
                if match(m):
                    m.persistent = False
            self._remove(lambda m: match(m) and not m.fault)

    def clear_fault_cause(self, axis: int | None = None) -> None:
        with self._lock:
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
            self._raise(Message(F08700, axis.do_number, reaction is not None, COMMUNICATION_ERROR_VALUE, True,
                                reaction or 'OFF2'))
        self._nmt_reaction(1)

    def on_life_guarding_recovered(self) -> None:
        for m in self.messages:
            if m.number == F08700 and m.value == COMMUNICATION_ERROR_VALUE:
                m.persistent = False
        self._remove(lambda m: m.number == F08700 and not m.fault)

    def on_heartbeat_lost(self, node: int) -> None:
        """The S120 consumes no heartbeat [2.2]."""

    def _rpdo_limit(self, exceeded: bool) -> None:
        if exceeded:
            self._raise(Message(A08758, CU, False, 0, True))
        else:
            self._remove(lambda m: m.number == A08758)

    def _telegram(self, pdo: Pdo, stamp: float) -> None:
        """An RPDO arrived: A08751 while its mean cycle is below 2 x p8848 [2.4, §2.10]."""
        rate = self._monitors.setdefault(pdo.number, _Rate())
        rate.update(stamp)
        do = self._slot_do(pdo.number)
        minimum = 2.0 * self.effective_p8848 / 1000.0
        if rate.samples >= TELEGRAM_SAMPLES and rate.mean < minimum * TELEGRAM_JITTER:
            self._raise(Message(A08751, do, False, 0, True))
        elif rate.mean >= minimum * TELEGRAM_HYSTERESIS:
            self._telegram_check(do, stamp)

    def _telegram_check(self, do: int, now: float) -> bool:
        """A08751 of ``do`` goes once none of its RPDOs comes too fast (or they stopped)."""
        if not any(m.number == A08751 and m.do == do for m in self.messages):
            return False
        minimum = 2.0 * self.effective_p8848 / 1000.0
        for number, rate in self._monitors.items():
            if self._slot_do(number) != do or rate.last is None or now - rate.last > TELEGRAM_SILENCE:
                continue
            if rate.mean < minimum * TELEGRAM_HYSTERESIS:
                return False
        return self._remove(lambda m: m.number == A08751 and m.do == do)

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
        with self._lock:
            if not self.powered:
                self._load_saved = self._power_cycle = True
            super().power_on()

    def set_address_switch(self, value: int) -> None:
        """Turn the Control Unit's address switch (0..255): read at the next POWER ON (module address)."""
        with self._lock:
            self.address_switch.set(value)

    def _read_node_id(self) -> None:
        """At POWER ON: the address switch, else the saved p8620 (module address)."""
        node_id, shown = self.address_switch.node_id(self.cu.get(8620))
        if shown:
            self.cu.set(8620, 0, node_id)
        change_node_id(self, node_id, self._factory)

    def reset_application(self) -> None:
        """Power-on and CU reboot load the saved parameters; NMT reset node keeps them (they are the
        drive's, not CANopen objects). Messages go, those with a persisting cause come back at boot."""
        if self._load_saved:
            self._load_saved = False
            self.cu.load_saved()
            for axis in self.s120_axes:
                axis.parameters.load_saved()
            self.selector = [0, 0, 0]
            if self._power_cycle or self.options['node_id_at_reboot']:
                self._read_node_id()
        self._power_cycle = False
        self.effective_p8848 = float(self.cu.get(8848))
        self._kept = [m for m in self.messages if m.persistent and m.number != F08700]
        self.messages = []
        self._monitors.clear()
        self._messages_changed()
        super().reset_application()

    def on_reset_communication(self) -> None:
        """0x1003 went back to its stored value with 0x1000..0x1FFF: it lists the messages still active."""
        self._write_history()

    def on_boot(self) -> None:
        super().on_boot()
        state = self.cu.get(8684)
        if state == 5:
            self.set_nmt_state(NmtState.OPERATIONAL)
        elif state == 4:
            self.set_nmt_state(NmtState.STOPPED)
        kept, self._kept = self._kept, []
        for message in kept:
            self._raise(message)

    # -- inspection (tests) -----------------------------------------------------------------------------
    def view(self, do: int = 0) -> DriveObjectView:
        """A snapshot of drive object ``do`` (0: the first axis; 1: the Control Unit)."""
        with self._lock:
            number = self._do(do)
            faults = tuple(m.number for m in self.messages if m.do == number and m.fault)
            alarms = tuple(m.number for m in self.messages if m.do == number and not m.fault)
            axis = self.axis_of(number)
            if axis is None:
                return DriveObjectView(number, None, '', 0, 0, 0, 0.0, 0.0, 0, 0, 0.0, 0.0, faults, alarms)
            mode = axis.mode
            if mode == 4:
                setpoint = float(axis.param(obj.TARGET_TORQUE, default=0))
            elif mode == 2:
                setpoint = float(axis.param(0x6042, default=0))
            else:
                setpoint = float(axis.param(obj.TARGET_VELOCITY, default=0))
            return DriveObjectView(
                number, axis.slot, axis.state.name, axis.compute_statusword(), mode, axis.requested_mode,
                axis.speed_rpm, axis.rpm(axis.dv), axis.to_bus(axis.v), axis.position if axis.encoder else 0,
                setpoint, axis.torque, faults, alarms)

    @property
    def views(self) -> tuple[DriveObjectView, ...]:
        return tuple(self.view(do) for do in (CU, *self.drive_objects))

    @property
    def active_messages(self) -> tuple[str, ...]:
        """'F07900@3', 'A08751@4', ... in order of occurrence."""
        with self._lock:
            return tuple(f'{m.label}@{m.do}' for m in self.messages)

    @property
    def valid_rpdos(self) -> int:
        with self._lock:
            return self.pdo.valid_rpdos  # type: ignore[attr-defined, no-any-return]
