"""The simulated OPEN drive as a CANopen node: :class:`SimOpenDrive`, registered as the
``opendrive`` simulator (what it reproduces: the package docstring)."""
from __future__ import annotations

import logging
import math
import struct
from collections.abc import Callable, Mapping
from typing import Any

import can
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.families.opendrive.parameter_table import (
    C52,
    C63,
    CONNECTIONS,
    EXTRA,
    P60,
    P99,
    P162,
    P163,
    PARAMETERS,
    RESERVED,
    TDE,
    Parameter,
)
from drive_bridge.model import NodeConfig
from drive_bridge.sim.opendrive import objects as o
from drive_bridge.sim.opendrive.emcy import OpenDriveEmcy
from drive_bridge.sim.opendrive.logic import TERMINAL_CONNECTIONS, LogicInputs
from drive_bridge.sim.opendrive.motor import Motor
from drive_bridge.sim.opendrive.options import OPENDRIVE_OPTIONS
from drive_bridge.sim.opendrive.pdo import OpenDrivePdoEngine
from drive_bridge.sim.opendrive.quantities import DIRECT, encode, full_scale
from drive_bridge.sim.registry import register_simulator
from drive_bridge.sim.slave import SimulatedSlave
from drive_bridge.sim.store import key

logger = logging.getLogger(__name__)

TWO_PI = 2.0 * math.pi
COMMUNICATION_STATE = (0x1001, 0x1003, o.STORE_PARAMETERS, o.RESTORE_PARAMETERS)  # not saved by 0x1010



def _words(words: list[int]) -> bytes:
    return struct.pack(f'<{len(words)}H', *(w & 0xFFFF for w in words))


def _abort(code: int) -> SdoAbortedError:
    return SdoAbortedError(code)


@register_simulator('opendrive')
class SimOpenDrive(SimulatedSlave):
    """A simulated OPEN drive (CiA 301 only, no CiA 402); see the package docstring."""

    OPTIONS = OPENDRIVE_OPTIONS
    PDO_ENGINE = OpenDrivePdoEngine
    EMCY_PRODUCER = OpenDriveEmcy

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        given = dict(options or {})
        if 'position_element' in given and given['position_element'] is None:
            given['position_element'] = -1
        super().__init__(node, options=given)
        opts = self.options
        elements = [opts['actual_speed_element'], opts['actual_torque_element']]
        if opts['position_element'] >= 0:
            elements.append(opts['position_element'])
        if len(set(elements)) != len(elements):
            raise ValueError(f'simulation options of node {node.name!r}: actual_speed_element, '
                             f'actual_torque_element and position_element must differ')
        self._offset: int = opts['array_offset']
        self._n_max = opts['n_max_rpm'] * TWO_PI / 60.0  # rad/s
        self.motor = Motor(opts['inertia'], opts['friction'], opts['speed_time_constant'],
                           opts['coast_time_constant'], self._n_max)
        self._factory_par = [0] * o.ARRAY_SIZES[o.TAB_PAR]
        self._factory_con = [0] * o.ARRAY_SIZES[o.TAB_CON]
        for p in PARAMETERS.values():
            self._factory_par[p.number] = _int16_raw(p.default)
        for c in CONNECTIONS.values():
            self._factory_con[c.number] = _int16_raw(c.default)
        self._factory_par[P162] = self.node_id
        self._factory_con[C52] = opts['c52']
        self._nv_par, self._nv_con = list(self._factory_par), list(self._factory_con)  # non-volatile memory
        self.tab_par, self.tab_con = list(self._nv_par), list(self._nv_con)
        for name in ('actual_speed_representation', 'actual_torque_representation'):
            try:
                full_scale(opts[name])
            except ValueError as error:
                raise ValueError(f'simulation option {name!r} of node {node.name!r}: {error}') from None
        self.logic = LogicInputs(lambda: self.tab_con, opts['terminal_run'])
        self._alarms = 0
        self._causes = 0  # alarms whose cause persists
        self._remote_cobs: set[int] = set()
        self._comm_keys = [k for k in self.store.variables
                           if 0x1000 <= k >> 8 <= 0x1FFF and k >> 8 not in COMMUNICATION_STATE]
        self._eds_comm = {k: self.store.defaults[k] for k in self._comm_keys}
        self._nv_comm = dict(self._eds_comm)
        self._domains = self._build_domains()
        self.od_emcy.alarms = lambda: self._alarms
        self._register_objects()

    @property
    def od_emcy(self) -> OpenDriveEmcy:
        return self.emcy  # type: ignore[return-value]

    @property
    def od_pdo(self) -> OpenDrivePdoEngine:
        return self.pdo  # type: ignore[return-value]

    # ---- inspection (tests) ------------------------------------------------------------------------
    @property
    def speed_rpm(self) -> float:
        """Actual motor speed, rpm."""
        with self._lock:
            return self.motor.speed * 60.0 / TWO_PI

    @property
    def torque_nm(self) -> float:
        with self._lock:
            return self.motor.torque

    @property
    def angle_rad(self) -> float:
        """Mechanical angle since power-on (not wrapped)."""
        with self._lock:
            return self.motor.angle

    @property
    def speed_reference_rpm(self) -> float:
        """The speed reference the drive applies now (0 without C52 = 1)."""
        with self._lock:
            return self._speed_reference() * 60.0 / TWO_PI

    @property
    def run_input(self) -> bool:
        """Logic input function RUN (0x2010[0] / 0x2021 bit 0): terminal AND fieldbus AND serial."""
        with self._lock:
            return bool(self.logic.standard & 1)

    @property
    def running(self) -> bool:
        """The inverter drives the motor: RUN high and no alarm."""
        with self._lock:
            return self._running()

    @property
    def run_channels(self) -> dict[str, bool]:
        """RUN of each channel (an unassigned terminal channel counts as high)."""
        with self._lock:
            terminal = self.logic.terminal_channel(o.RUN)
            return {'terminal': terminal is None or terminal, 'fieldbus': bool(self.logic.fieldbus & 1),
                    'serial': bool(self.logic.serial & 1)}

    @property
    def logic_inputs(self) -> int:
        """The 32 standard logic input functions (0x2021)."""
        with self._lock:
            return self.logic.standard

    @property
    def application_inputs(self) -> int:
        """The application logic input functions I29..I60 (0x2022)."""
        with self._lock:
            return self.logic.application_state

    @property
    def alarms(self) -> int:
        """0x2018: bit n = alarm An."""
        with self._lock:
            return self._alarms

    @property
    def alarm_enable(self) -> int:
        """0x2019 (= P163)."""
        with self._lock:
            return self.tab_par[P163] & 0xFFFF

    def parameter(self, number: int) -> int:
        """Pn in internal units (unsigned for unsigned parameters)."""
        with self._lock:
            return _internal(PARAMETERS.get(number), self.tab_par[number])

    def connection(self, number: int) -> int:
        with self._lock:
            return _internal(CONNECTIONS.get(number), self.tab_con[number])

    def saved_parameter(self, number: int) -> int:
        """Pn as kept in the non-volatile memory."""
        with self._lock:
            return _internal(PARAMETERS.get(number), self._nv_par[number])

    def saved_connection(self, number: int) -> int:
        with self._lock:
            return _internal(CONNECTIONS.get(number), self._nv_con[number])

    # ---- test-side switches ------------------------------------------------------------------------
    def set_terminal(self, number: int, on: bool) -> None:
        """Terminal input ``number`` (1..8) high or low (0x2013 bit number - 1)."""
        with self._lock:
            self.logic.set_terminal(number, on)
            self._logic_changed()

    def set_terminal_input(self, function: int, on: bool) -> None:
        """Every terminal input assigned to logic function ``function`` (C1..C8) high or low."""
        with self._lock:
            numbers = self.logic.terminals_of(function)
            if not numbers:
                raise ValueError(f'no terminal input is assigned to logic function {function} (C1..C8)')
            for n in numbers:
                self.logic.set_terminal(n, on)
            self._logic_changed()

    def set_serial_input(self, function: int, on: bool) -> None:
        """The serial-line channel of standard logic function ``function`` (RUN starts high)."""
        with self._lock:
            self.logic.set_serial(function, on)
            self._logic_changed()

    def inject_alarm(self, number: int, persistent: bool = False) -> None:
        """Alarm A``number`` trips; ``persistent``: its cause stays until :meth:`clear_alarm_cause`
        (a reset does not clear it before), else the cause is gone at once."""
        if not 0 <= number <= 15:
            raise ValueError(f'alarm A{number}: the drive has A0..A15')
        with self._lock:
            if persistent:
                self._causes |= 1 << number
            if self.powered:
                self._trip(number)
                self.pdo.poll_events()

    def clear_alarm_cause(self, number: int) -> None:
        """The cause of alarm A``number`` is gone: the next alarm reset clears it."""
        with self._lock:
            self._causes &= ~(1 << number)

    # ---- objects -------------------------------------------------------------------------------
    def _register_objects(self) -> None:
        store = self.store

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if key(index, subindex) in store:
                self.register_object(index, subindex, **hooks)

        def signature(expected: int) -> Callable[[int], None]:
            def check(value: int) -> None:
                if value != expected:
                    raise _abort(o.ABORT_NOT_STORED)
            return check

        reg(o.STORE_PARAMETERS, 1, reader=lambda: 1, validator=signature(o.SIGNATURE_SAVE),
            on_write=lambda value: self._save(parameters=True))
        reg(o.STORE_PARAMETERS, 2, reader=lambda: 1, validator=signature(o.SIGNATURE_SAVE),
            on_write=lambda value: self._save(parameters=False))
        reg(o.RESTORE_PARAMETERS, 1, reader=lambda: 1, validator=signature(o.SIGNATURE_LOAD),
            on_write=lambda value: self._restore(parameters=True))
        reg(o.RESTORE_PARAMETERS, 2, reader=lambda: 1, validator=signature(o.SIGNATURE_LOAD),
            on_write=lambda value: self._restore(parameters=False))
        for index, data in self._domains.items():
            reg(index, reader=lambda data=data: data)
        for number in range(1, 5):  # RTR-only TPDOs listen for remote frames
            for sub in (1, 2):
                reg(0x1800 + number - 1, sub, on_write=lambda value: self._update_remote_frames())

        for index, size in o.ARRAY_SIZES.items():
            for sub in range(1, size + 1):
                element = sub - self._offset
                if not 0 <= element < size:
                    reg(index, sub, validator=self._no_element)
                    continue
                if index == o.TAB_PAR:
                    reg(index, sub, reader=lambda e=element: self.tab_par[e],
                        validator=lambda v, e=element: self._check_parameter('P', e, v),
                        on_write=lambda v, e=element: self._set_parameter('P', e, v))
                elif index == o.TAB_CON:
                    reg(index, sub, reader=lambda e=element: self.tab_con[e],
                        validator=lambda v, e=element: self._check_parameter('C', e, v),
                        on_write=lambda v, e=element: self._set_parameter('C', e, v))
                elif index in (o.TAB_INT, o.TAB_OSC):
                    reg(index, sub, reader=lambda e=element: self._quantity(e))
                elif index == o.TAB_INP_DIG:
                    reg(index, sub, reader=lambda e=element: o.HIGH if self.logic.standard >> e & 1 else 0)
                elif index == o.TAB_INP_DIG_FIELD:
                    reg(index, sub, reader=lambda e=element: o.HIGH if self.logic.fieldbus >> e & 1 else 0,
                        on_write=lambda v, e=element: self._set_fieldbus_function(e, v))
        reg(o.INGRESSI, reader=lambda: self.logic.terminals)
        reg(o.ALLARMI, reader=lambda: self._alarms)
        reg(o.ABILITAZIONE_ALLARMI, reader=lambda: self.tab_par[P163] & 0xFFFF)
        reg(o.INGRESSI_STANDARD_WR, reader=lambda: self.logic.fieldbus, on_write=self._set_fieldbus)
        reg(o.INGRESSI_APPL_WR, reader=lambda: self.logic.application, on_write=self._set_application)
        reg(o.INGRESSI_STANDARD_RD, reader=lambda: self.logic.standard)
        reg(o.INGRESSI_APPL_RD, reader=lambda: self.logic.application_state)

    def _build_domains(self) -> dict[int, bytes]:
        def table(entries: Mapping[int, Parameter], count: int) -> bytes:
            words: list[int] = []
            for number in range(count):
                entry = entries.get(number)
                words += entry.words() if entry is not None else [0, 0, 0, 0]
            return _words(words)

        extra: list[int] = []
        for number in range(100):
            extra += list(EXTRA.get(number, (0, 0, 0, 0, 0)))
        representations = _words([self._representation(e) for e in range(64)])
        monitor = bytes(2 * o.MONITOR_POINTS)
        return {o.TAB_FORMATI: table(PARAMETERS, 200), o.TAB_CON_FORMATI: table(CONNECTIONS, 100),
                o.TAB_EXP_INT: representations, o.TAB_EXP_OSC: representations,
                o.TAB_PAR_DEF: _words(self._factory_par), o.TAB_CON_DEF: _words(self._factory_con),
                o.TAB_MONITOR_A: monitor, o.TAB_MONITOR_B: monitor, o.TAB_FORMATI_EXTRA: _words(extra)}

    def _representation(self, element: int) -> int:
        """The representation word of Tab_osc / Tab_int element ``element`` (module quantities)."""
        opts = self.options
        if element == opts['actual_speed_element']:
            return int(opts['actual_speed_representation'])
        if element == opts['actual_torque_element']:
            return int(opts['actual_torque_representation'])
        if element == opts['position_element']:
            return DIRECT
        return 0

    def _quantity(self, element: int) -> int:
        opts, motor = self.options, self.motor
        if element == opts['actual_speed_element']:
            return encode(motor.speed / self._n_max, opts['actual_speed_representation'])
        if element == opts['actual_torque_element']:
            return encode(motor.torque / opts['rated_torque'], opts['actual_torque_representation'])
        if element == opts['position_element']:
            counts = int(round(motor.angle / TWO_PI * o.PULSES_PER_REVOLUTION)) & 0xFFFF
            return counts - 0x10000 if counts >= 0x8000 else counts
        return 0

    @staticmethod
    def _no_element(value: Any) -> None:
        raise _abort(o.ABORT_NO_SUBINDEX)

    # ---- parameters ----------------------------------------------------------------------------
    def _check_parameter(self, letter: str, element: int, value: int) -> None:
        """The rules of a keypad write (§2.2 item 2): managed slot, class, range."""
        entry = (PARAMETERS if letter == 'P' else CONNECTIONS).get(element)
        if entry is None or entry.access_class == 0:
            raise _abort(o.ABORT_READ_ONLY)
        if entry.access_class in (RESERVED, TDE):
            if self._running():
                raise _abort(o.ABORT_STATE)
            key_parameter, wanted = (P60, self.options['reserved_key']) if entry.access_class == RESERVED \
                else (P99, self.options['tde_key'])
            if self.tab_par[key_parameter] & 0xFFFF != wanted:
                raise _abort(o.ABORT_NOT_STORED)
        internal = entry.internal(value)
        if internal < entry.low:
            raise _abort(o.ABORT_TOO_LOW)
        if internal > entry.high:
            raise _abort(o.ABORT_TOO_HIGH)

    def _set_parameter(self, letter: str, element: int, value: int) -> None:
        if letter == 'P':
            self.tab_par[element] = value
            return
        self.tab_con[element] = value
        if element == C63 and value == 1:  # save to the non-volatile memory; C63 reads 0 again
            self.tab_con[C63] = 0
            self._save_drive_parameters()
        elif element in TERMINAL_CONNECTIONS:
            self._logic_changed()

    def _save_drive_parameters(self) -> None:
        self._nv_par, self._nv_con = list(self.tab_par), list(self.tab_con)
        self._nv_con[C63] = 0

    def _save(self, parameters: bool) -> None:
        """0x1010: the communication objects (sub 1: and the drive parameters) to non-volatile
        memory; resets load them from then on."""
        values = self.store.values
        for k in self._comm_keys:
            self._nv_comm[k] = self.store.defaults[k] = values[k]
        if parameters:
            self._save_drive_parameters()

    def _restore(self, parameters: bool) -> None:
        """0x1011: the default communication objects (sub 1: and the factory drive parameters)
        are written to non-volatile memory; they take effect at the next power-on."""
        self._nv_comm = dict(self._eds_comm)
        if parameters:
            self._nv_par, self._nv_con = list(self._factory_par), list(self._factory_con)

    def power_on(self) -> None:
        """Power-on: the communication objects come from the non-volatile memory."""
        with self._lock:
            if not self.powered:
                for k, value in self._nv_comm.items():
                    self.store.defaults[k] = value
        super().power_on()

    # ---- logic functions (module logic) ---------------------------------------------------------
    def _logic_changed(self) -> None:
        old = self.logic.standard
        self.logic.compute()
        bit = 1 << self.options['alarm_reset_function']
        if self.logic.standard & bit and not old & bit:
            self._reset_alarms()
        self.pdo.poll_events()

    def _set_fieldbus(self, value: int) -> None:
        self.logic.fieldbus = value & 0xFFFFFFFF
        self._logic_changed()

    def _set_fieldbus_function(self, function: int, value: int) -> None:
        self.logic.set_fieldbus_function(function, value)
        self._logic_changed()

    def _set_application(self, value: int) -> None:
        self.logic.application = value & 0xFFFFFFFF
        self._logic_changed()

    def _running(self) -> bool:
        return bool(self.logic.standard & 1) and not self._alarms

    # ---- alarms --------------------------------------------------------------------------------
    def _trip(self, number: int) -> None:
        bit = 1 << number
        if self._alarms & bit:
            return  # latched already: no new event
        self._alarms |= bit
        if self.tab_par[P163] & bit:
            self.od_emcy.alarm_event(o.EMCY_GENERIC, self._alarms, history=True)

    def _reset_alarms(self) -> None:
        """Alarm reset: the alarms whose cause is gone are cleared, EMCY 0x0000 with the rest."""
        cleared = self._alarms & ~self._causes
        if not cleared:
            return
        self._alarms &= ~cleared
        self.od_emcy.alarm_event(o.EMCY_RESET, self._alarms, history=False)

    # ---- motor ---------------------------------------------------------------------------------
    def _speed_reference(self) -> float:
        """rad/s, from the selected reference object (0 without C52 = 1)."""
        if self.tab_con[C52] != 1:
            return 0.0
        values, opts = self.store.values, self.options
        if opts['speed_reference'] == '0x201A':
            return values[key(o.F_FIELDBUS)] / o.SPEED_FULL_SCALE * self._n_max
        return values[key(o.THETA_FIELDBUS)] * opts['pwm_frequency'] * TWO_PI / (
            o.PULSES_PER_REVOLUTION * opts['pole_pairs'])

    def _model_step(self, dt: float, sync: bool) -> None:
        opts, values = self.options, self.store.values
        rated = opts['rated_torque']
        if self.tab_con[C52] == 1:
            torque_ref = values[key(o.TRIF_FIELDBUS)] / o.TORQUE_FULL_SCALE * rated
            limit = abs(values[key(o.LIMIT_FIELDBUS)]) / o.TORQUE_FULL_SCALE * rated
        else:
            torque_ref, limit = 0.0, 32767 / o.TORQUE_FULL_SCALE * rated
        self.motor.step(dt, self._running(), opts['control_mode'] == 'torque', self._speed_reference(),
                        torque_ref, limit)

    # ---- hooks of the CiA 301 slave --------------------------------------------------------------
    def reset_application(self) -> None:
        """Power-on / reset node: parameters from non-volatile memory, fieldbus RUN high, no alarm."""
        self.tab_par, self.tab_con = list(self._nv_par), list(self._nv_con)
        self._alarms = 0
        self.motor.reset()
        self.logic.reset()

    def on_boot(self) -> None:
        for number in range(16):  # causes still present trip their alarm again
            if self._causes >> number & 1:
                self._trip(number)
        self._update_remote_frames()

    def expedited_download(self, index: int, subindex: int, data: bytes, request: bytes) -> bytes:
        if not request[0] & 0x01:  # the size indicator is mandatory (§2.2 item 1)
            raise _abort(o.ABORT_NO_SIZE)
        return data

    def life_time_limit(self) -> float:
        return 32767.0 / self.options['pwm_frequency']

    def on_life_guarding_lost(self) -> None:
        """The firmware's reaction (option life_guarding_reaction): none, RUN low, or an alarm."""
        reaction = self.options['life_guarding_reaction']
        if reaction == 'stop':
            self.logic.guard_stop = True
            self._logic_changed()
        elif reaction == 'alarm':
            self._causes |= 1 << self.options['guarding_alarm']  # until the RTRs come back
            self._trip(self.options['guarding_alarm'])
            self.pdo.poll_events()

    def on_life_guarding_recovered(self) -> None:
        if self.logic.guard_stop:
            self.logic.guard_stop = False
            self._logic_changed()
        if self.options['life_guarding_reaction'] == 'alarm':
            self._causes &= ~(1 << self.options['guarding_alarm'])  # an alarm reset clears it now

    # ---- RTR-only TPDOs ------------------------------------------------------------------------
    def _update_remote_frames(self) -> None:
        frames = self.remote_frames()
        wanted = self.od_pdo.remote_cob_ids() if frames is not None else set()
        if frames is not None:
            for cob in self._remote_cobs - wanted:
                frames.remove(cob)
            for cob in wanted - self._remote_cobs:
                frames.add(cob, self._on_pdo_remote_request)
        self._remote_cobs = wanted

    def _on_pdo_remote_request(self, msg: can.Message) -> None:
        try:
            with self._lock:
                if self.powered and not self.faults.muted:
                    self.od_pdo.on_remote_request(msg.arbitration_id)
        except Exception:  # never let an exception stop the shared Notifier
            logger.exception('%s: RTR-only TPDO failed', self.name)

    def detach(self) -> None:
        with self._lock:
            frames = self.remote_frames()
            if frames is not None:
                for cob in self._remote_cobs:
                    frames.remove(cob)
            self._remote_cobs = set()
        super().detach()


def _int16_raw(value: int) -> int:
    """A table value as the INT16 array holds it."""
    value &= 0xFFFF
    return value - 0x10000 if value >= 0x8000 else value


def _internal(entry: Parameter | None, raw: int) -> int:
    return entry.internal(raw) if entry is not None else raw
