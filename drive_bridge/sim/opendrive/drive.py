"""The simulated OPEN drive as a CANopen node: :class:`SimOpenDrive`, registered as the
``opendrive`` simulator (what it reproduces: the package docstring)."""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.families.opendrive.parameter_table import (
    C52,
    C63,
    CONNECTIONS,
    P60,
    P99,
    P163,
    PARAMETERS,
    RESERVED,
    TDE,
    Parameter,
)
from drive_bridge.model import NodeConfig
from drive_bridge.sim.opendrive import objects as o
from drive_bridge.sim.opendrive.alarms import Alarms
from drive_bridge.sim.opendrive.emcy import OpenDriveEmcy
from drive_bridge.sim.opendrive.formats import format_domains
from drive_bridge.sim.opendrive.logic import TERMINAL_CONNECTIONS, LogicInputs
from drive_bridge.sim.opendrive.memory import NonVolatileMemory
from drive_bridge.sim.opendrive.motor import Motor
from drive_bridge.sim.opendrive.options import OPENDRIVE_OPTIONS, check_options
from drive_bridge.sim.opendrive.pdo import OpenDrivePdoEngine
from drive_bridge.sim.opendrive.quantities import actual_value, representation
from drive_bridge.sim.opendrive.references import speed_reference, torque_reference
from drive_bridge.sim.opendrive.remote import RemoteTpdos
from drive_bridge.sim.registry import register_simulator
from drive_bridge.sim.slave import SimulatedSlave
from drive_bridge.sim.store import key

TWO_PI = 2.0 * math.pi



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
        check_options(node.name, opts)
        self._offset: int = opts['array_offset']
        self._n_max = opts['n_max_rpm'] * TWO_PI / 60.0  # rad/s
        self.motor = Motor(opts['inertia'], opts['friction'], opts['speed_time_constant'],
                           opts['coast_time_constant'], self._n_max)
        self.memory = NonVolatileMemory(self.store, self.node_id, opts['c52'])
        self.tab_par, self.tab_con = list(self.memory.par), list(self.memory.con)
        self.logic = LogicInputs(lambda: self.tab_con, opts['terminal_run'])
        self.alarm_state = Alarms(self.od_emcy, lambda: self.tab_par[P163])
        self.remote_tpdos = RemoteTpdos(self.name, self.remote_frames, self.od_pdo, self.lock,
                                        lambda: self.powered and not self.faults.muted)
        self._domains = format_domains(self.memory.factory_par, self.memory.factory_con,
                                       lambda element: representation(opts, element))
        self.od_emcy.alarms = lambda: self.alarm_state.active
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
        with self.lock:
            return self.motor.speed * 60.0 / TWO_PI

    @property
    def torque_nm(self) -> float:
        with self.lock:
            return self.motor.torque

    @property
    def angle_rad(self) -> float:
        """Mechanical angle since power-on (not wrapped)."""
        with self.lock:
            return self.motor.angle

    @property
    def speed_reference_rpm(self) -> float:
        """The speed reference the drive applies now (0 without C52 = 1)."""
        with self.lock:
            return self._speed_reference() * 60.0 / TWO_PI

    @property
    def run_input(self) -> bool:
        """Logic input function RUN (0x2010[0] / 0x2021 bit 0): terminal AND fieldbus AND serial."""
        with self.lock:
            return bool(self.logic.standard & 1)

    @property
    def running(self) -> bool:
        """The inverter drives the motor: RUN high and no alarm."""
        with self.lock:
            return self._running()

    @property
    def run_channels(self) -> dict[str, bool]:
        """RUN of each channel (an unassigned terminal channel counts as high)."""
        with self.lock:
            terminal = self.logic.terminal_channel(o.RUN)
            return {'terminal': terminal is None or terminal, 'fieldbus': bool(self.logic.fieldbus & 1),
                    'serial': bool(self.logic.serial & 1)}

    @property
    def logic_inputs(self) -> int:
        """The 32 standard logic input functions (0x2021)."""
        with self.lock:
            return self.logic.standard

    @property
    def application_inputs(self) -> int:
        """The application logic input functions I29..I60 (0x2022)."""
        with self.lock:
            return self.logic.application_state

    @property
    def alarms(self) -> int:
        """0x2018: bit n = alarm An."""
        with self.lock:
            return self.alarm_state.active

    @property
    def alarm_enable(self) -> int:
        """0x2019 (= P163)."""
        with self.lock:
            return self.tab_par[P163] & 0xFFFF

    def parameter(self, number: int) -> int:
        """Pn in internal units (unsigned for unsigned parameters)."""
        with self.lock:
            return _internal(PARAMETERS.get(number), self.tab_par[number])

    def connection(self, number: int) -> int:
        with self.lock:
            return _internal(CONNECTIONS.get(number), self.tab_con[number])

    def saved_parameter(self, number: int) -> int:
        """Pn as kept in the non-volatile memory."""
        with self.lock:
            return _internal(PARAMETERS.get(number), self.memory.par[number])

    def saved_connection(self, number: int) -> int:
        with self.lock:
            return _internal(CONNECTIONS.get(number), self.memory.con[number])

    # ---- test-side switches ------------------------------------------------------------------------
    def set_terminal(self, number: int, on: bool) -> None:
        """Terminal input ``number`` (1..8) high or low (0x2013 bit number - 1)."""
        with self.lock:
            self.logic.set_terminal(number, on)
            self._logic_changed()

    def set_terminal_input(self, function: int, on: bool) -> None:
        """Every terminal input assigned to logic function ``function`` (C1..C8) high or low."""
        with self.lock:
            numbers = self.logic.terminals_of(function)
            if not numbers:
                raise ValueError(f'no terminal input is assigned to logic function {function} (C1..C8)')
            for n in numbers:
                self.logic.set_terminal(n, on)
            self._logic_changed()

    def set_serial_input(self, function: int, on: bool) -> None:
        """The serial-line channel of standard logic function ``function`` (RUN starts high)."""
        with self.lock:
            self.logic.set_serial(function, on)
            self._logic_changed()

    def inject_alarm(self, number: int, persistent: bool = False) -> None:
        """Alarm A``number`` trips; ``persistent``: its cause stays until :meth:`clear_alarm_cause`
        (a reset does not clear it before), else the cause is gone at once."""
        if not 0 <= number <= 15:
            raise ValueError(f'alarm A{number}: the drive has A0..A15')
        with self.lock:
            if persistent:
                self.alarm_state.causes |= 1 << number
            if self.powered:
                self.alarm_state.trip(number)
                self.pdo.poll_events()

    def clear_alarm_cause(self, number: int) -> None:
        """The cause of alarm A``number`` is gone: the next alarm reset clears it."""
        with self.lock:
            self.alarm_state.causes &= ~(1 << number)

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
            on_write=lambda value: self.memory.save(True, self.tab_par, self.tab_con))
        reg(o.STORE_PARAMETERS, 2, reader=lambda: 1, validator=signature(o.SIGNATURE_SAVE),
            on_write=lambda value: self.memory.save(False, self.tab_par, self.tab_con))
        reg(o.RESTORE_PARAMETERS, 1, reader=lambda: 1, validator=signature(o.SIGNATURE_LOAD),
            on_write=lambda value: self.memory.restore(True))
        reg(o.RESTORE_PARAMETERS, 2, reader=lambda: 1, validator=signature(o.SIGNATURE_LOAD),
            on_write=lambda value: self.memory.restore(False))
        for index, data in self._domains.items():
            reg(index, reader=lambda data=data: data)
        for number in range(1, 5):  # RTR-only TPDOs listen for remote frames
            for sub in (1, 2):
                reg(0x1800 + number - 1, sub, on_write=lambda value: self.remote_tpdos.update())

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
                    reg(index, sub, reader=lambda e=element: actual_value(self.options, self.motor, self._n_max, e))
                elif index == o.TAB_INP_DIG:
                    reg(index, sub, reader=lambda e=element: o.HIGH if self.logic.standard >> e & 1 else 0)
                elif index == o.TAB_INP_DIG_FIELD:
                    reg(index, sub, reader=lambda e=element: o.HIGH if self.logic.fieldbus >> e & 1 else 0,
                        on_write=lambda v, e=element: self._set_fieldbus_function(e, v))
        reg(o.INGRESSI, reader=lambda: self.logic.terminals)
        reg(o.ALLARMI, reader=lambda: self.alarm_state.active)
        reg(o.ABILITAZIONE_ALLARMI, reader=lambda: self.tab_par[P163] & 0xFFFF)
        reg(o.INGRESSI_STANDARD_WR, reader=lambda: self.logic.fieldbus, on_write=self._set_fieldbus)
        reg(o.INGRESSI_APPL_WR, reader=lambda: self.logic.application, on_write=self._set_application)
        reg(o.INGRESSI_STANDARD_RD, reader=lambda: self.logic.standard)
        reg(o.INGRESSI_APPL_RD, reader=lambda: self.logic.application_state)

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
            self.memory.save_drive_parameters(self.tab_par, self.tab_con)
        elif element in TERMINAL_CONNECTIONS:
            self._logic_changed()

    def power_on(self) -> None:
        """Power-on: the communication objects come from the non-volatile memory."""
        with self.lock:
            if not self.powered:
                self.memory.load_communication()
        super().power_on()

    # ---- logic functions (module logic) ---------------------------------------------------------
    def _logic_changed(self) -> None:
        old = self.logic.standard
        self.logic.compute()
        bit = 1 << self.options['alarm_reset_function']
        if self.logic.standard & bit and not old & bit:
            self.alarm_state.reset()
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
        return bool(self.logic.standard & 1) and not self.alarm_state.active

    # ---- motor ---------------------------------------------------------------------------------
    def _speed_reference(self) -> float:
        """rad/s, from the selected reference object (0 without C52 = 1)."""
        return speed_reference(self.store.values, self.options, self.tab_con[C52] == 1, self._n_max)

    def model_step(self, dt: float, sync: bool) -> None:
        torque_ref, limit = torque_reference(self.store.values, self.options, self.tab_con[C52] == 1)
        self.motor.step(dt, self._running(), self.options['control_mode'] == 'torque', self._speed_reference(),
                        torque_ref, limit)

    # ---- hooks of the CiA 301 slave --------------------------------------------------------------
    def reset_application(self) -> None:
        """Power-on / reset node: parameters from non-volatile memory, fieldbus RUN high, no alarm."""
        self.tab_par, self.tab_con = list(self.memory.par), list(self.memory.con)
        self.alarm_state.active = 0
        self.motor.reset()
        self.logic.reset()

    def on_boot(self) -> None:
        self.alarm_state.trip_persisting()
        self.remote_tpdos.update()

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
            self.alarm_state.causes |= 1 << self.options['guarding_alarm']  # until the RTRs come back
            self.alarm_state.trip(self.options['guarding_alarm'])
            self.pdo.poll_events()

    def on_life_guarding_recovered(self) -> None:
        if self.logic.guard_stop:
            self.logic.guard_stop = False
            self._logic_changed()
        if self.options['life_guarding_reaction'] == 'alarm':
            self.alarm_state.causes &= ~(1 << self.options['guarding_alarm'])  # an alarm reset clears it now

    def detach(self) -> None:
        with self.lock:
            self.remote_tpdos.detach()
        super().detach()

def _internal(entry: Parameter | None, raw: int) -> int:
    return entry.internal(raw) if entry is not None else raw
