"""One simulated CiA 402 axis: the device state machine driven by the controlword,
stop and fault reactions, the statusword, and the motion model stepping.

Choices where CiA 402 leaves room (a master must cope with all of them on real drives):

- A device control command with bit 7 set is not evaluated outside Fault (bit 7 is
  "fault reset"; a master must drop it before sending shutdown).
- Fault reset acts on the rising edge of bit 7 only, and fails (stays in Fault) while
  the cause persists: a persistent injected fault or a lost master heartbeat.
- Transitions 5 and 8 with option code 1 (0x605C / 0x605B) ramp down in Operation
  Enabled first, then switch; a ramp is the slow-down ramp 0x6084, the quick-stop
  ramp 0x6085, or for "current/voltage limit" (3, 4, 7, 8) the max deceleration 0x60C6.
- Quick stop option codes outside 0..8 behave as 2; halt option 0 behaves as 1.
- In torque modes, halt and quick stop brake the load by velocity control.
- Position values persist over NMT resets and power cycles (absolute encoder).
- Statusword: bit 4 (voltage enabled) from Ready to Switch On up to Fault Reaction
  Active, bit 9 (remote) always, bit 7 (warning) after an IP buffer overflow, bit 11
  while a target was clamped to or the demand stands at a software limit 0x607D
  (limits active when min < max).
- A stop ramp starts from the demand, or from the actual motion when the two differ
  by more than the following error window (after a set-point jump).
- Following error (0x6065/0x6066) is monitored in PP, HM, IP and CSP, in Operation
  Enabled and Quick Stop Active; window 0xFFFFFFFF switches it off.
"""
from __future__ import annotations

import math
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import SUPPORT_BITS, Mode
from drive_bridge.cia402.statemachine import (
    CW_ENABLE_OPERATION,
    CW_ENABLE_VOLTAGE,
    CW_FAULT_RESET,
    CW_HALT,
    CW_QUICK_STOP,
    CW_SWITCH_ON,
    SW_INTERNAL_LIMIT,
    SW_REMOTE,
    SW_TARGET_REACHED,
    SW_VOLTAGE_ENABLED,
    SW_WARNING,
    State,
    statusword_bits_for,
)
from drive_bridge.sim.interfaces import AxisDrive
from drive_bridge.sim.ipbuffer import IpBuffer
from drive_bridge.sim.motion import (
    clamp,
    lag_follow,
    max_acceleration,
    motor_torque,
    stop_step,
    torque_drive,
    wrap_int32,
)
from drive_bridge.sim.opmodes import IMPLEMENTED_MODES, OpMode, make_mode
from drive_bridge.sim.store import key

ABORT_VALUE_RANGE = 0x06090030
EMCY_FOLLOWING_ERROR = 0x8611
TORQUE_DEMAND = 0x6074
ENERGISED = frozenset({State.OPERATION_ENABLED, State.QUICK_STOP_ACTIVE, State.FAULT_REACTION_ACTIVE})
VOLTAGE_STATES = frozenset({State.READY_TO_SWITCH_ON, State.SWITCHED_ON, *ENERGISED})
STANDSTILL = 1.0  # counts/s: below this the axis counts as stopped
STOP_SETTLE_MAX = 0.2  # s: a stop ramp ends at the latest this long after the demand reached 0


_CACHED_PARAMETERS = (
    (obj.MAX_MOTOR_SPEED, 0), (obj.MAX_PROFILE_VELOCITY, 0), (obj.PROFILE_VELOCITY, 0),
    (obj.PROFILE_ACCELERATION, 0), (obj.PROFILE_DECELERATION, 0), (obj.MAX_ACCELERATION, 0),
    (obj.MAX_DECELERATION, 0), (obj.QUICK_STOP_DECELERATION, 0), (obj.MAX_TORQUE, 0),
    (obj.SOFTWARE_POSITION_LIMIT, 1), (obj.SOFTWARE_POSITION_LIMIT, 2), (obj.INTERPOLATION_TIME_PERIOD, 1),
    (obj.INTERPOLATION_TIME_PERIOD, 2), (obj.FOLLOWING_ERROR_WINDOW, 0), (obj.FOLLOWING_ERROR_TIMEOUT, 0),
)


class _Stop:
    """A running stop ramp and what follows it."""

    __slots__ = ('reason', 'deceleration', 'then', 'finished', 'settling')

    def __init__(self, reason: str, deceleration: float, then: State | None) -> None:
        self.reason = reason  # halt, quick_stop, fault, disable_operation, shutdown
        self.deceleration = max(deceleration, 1.0)
        self.then = then  # state entered when stopped (None: stay)
        self.finished = False
        self.settling = 0.0  # s the demand has stood still while the motor settles


class Axis402:
    """The axis in ``slot`` of a simulated drive; its objects sit at index + 0x800 * slot.

    Hooks a drive family's axis overrides (the defaults are the behaviour described above):

    - :meth:`register_objects` -- the axis' dynamic objects (extend: call super() first);
    - :meth:`motion_parameters` -- derived motion parameters (ramps, limits, windows);
    - :meth:`load_boot_values` -- what the drive reads only at power-on / reset node;
    - :meth:`supports`, :meth:`check_mode`, :meth:`set_mode`, :meth:`mode_for` -- which modes,
      when a mode change takes effect, and the mode objects;
    - :meth:`on_controlword` -- a written controlword;
    - :meth:`on_transition` -- after every device state transition;
    - :meth:`compute_statusword`, :meth:`param`, :meth:`reset`, :meth:`advance`;

    and a drive acknowledges its faults by other means through :meth:`acknowledge_fault`; a
    family whose error reactions are not the Fault state acts through :meth:`enter_state`,
    :meth:`brake` and :meth:`release_brake`.
    """

    def __init__(self, drive: AxisDrive, slot: int, options: dict[str, Any]) -> None:
        self.drive = drive
        self.slot = slot
        self._values = drive.store.values
        self._keys: dict[tuple[int, int], int] = {}
        self.lag = float(options['lag_time_constant'])
        self.inertia = float(options['inertia'])
        self.friction = float(options['friction'])
        self.switch_position = float(options['home_switch_position'])
        self.homing_timeout = float(options['homing_timeout'])
        # plant (actual) and demand
        self.p = float(options['initial_position'])
        self.v = 0.0
        self.torque = 0.0
        self.dp, self.dv, self.dtorque = self.p, 0.0, 0.0
        self.state = State.NOT_READY_TO_SWITCH_ON
        self.controlword = 0
        self.mode_impl: OpMode = self.mode_for(Mode.NO_MODE)
        self.fault_code = 0
        self.persistent_fault = False
        self.persistent_code = 0
        self.halted = False
        self.sync_driven = False
        self.fe_active = False
        self._fe_time = 0.0
        self._limited = False
        self.ip = IpBuffer(lambda: int(self.param(obj.INTERPOLATION_DATA_CONFIGURATION, 1, default=16)))
        self._stop: _Stop | None = None
        self._cache: dict[str, Any] | None = None
        self._stepping = False
        self._step_shift = 0.0
        self.declared_modes: int | None = None  # modes of a drive without 0x6502 (None: all it implements)
        self.register_objects()
        self.load_boot_values()

    # ---- objects -------------------------------------------------------------------
    def key(self, index: int, subindex: int = 0) -> int:
        k = self._keys.get((index, subindex))
        if k is None:
            k = self._keys[(index, subindex)] = key(obj.for_axis(index, self.slot), subindex)
        return k

    def param(self, index: int, subindex: int = 0, default: Any = None) -> Any:
        """A parameter of this axis (index given for axis 0)."""
        value = self._values.get(self.key(index, subindex), default)
        if value is None:
            raise KeyError(f'axis {self.slot}: 0x{obj.for_axis(index, self.slot):04X}:{subindex:02X} missing')
        return value

    def register_objects(self) -> None:
        """Hook: make the axis' objects dynamic (readers, validators, reactions)."""
        d = self.drive

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if self.key(index, subindex) in d.store:
                d.register_object(obj.for_axis(index, self.slot), subindex, **hooks)

        reg(obj.CONTROLWORD, on_write=self.on_controlword)
        reg(obj.STATUSWORD, reader=self.compute_statusword)
        reg(obj.MODES_OF_OPERATION, validator=self.check_mode, on_write=self.set_mode, early=True)
        reg(obj.MODES_OF_OPERATION_DISPLAY, reader=lambda: self.mode_impl.code)
        reg(obj.ERROR_CODE, reader=lambda: self.fault_code)
        reg(obj.POSITION_DEMAND, reader=lambda: wrap_int32(self.dp))
        reg(obj.POSITION_ACTUAL, reader=lambda: wrap_int32(self.p))
        reg(obj.VELOCITY_DEMAND, reader=lambda: wrap_int32(self.dv))
        reg(obj.VELOCITY_ACTUAL, reader=lambda: wrap_int32(self.v))
        reg(obj.TORQUE_ACTUAL, reader=lambda: int(round(clamp(self.torque, -32768, 32767))))
        reg(TORQUE_DEMAND, reader=lambda: int(round(clamp(self.torque_demand(), -32768, 32767))))
        reg(obj.FOLLOWING_ERROR_ACTUAL, reader=lambda: wrap_int32(self.dp - self.p))
        reg(obj.INTERPOLATION_SUB_MODE, validator=self._check_ip_submode)
        reg(obj.INTERPOLATION_DATA_RECORD, 1, on_write=self.ip.push)
        reg(obj.INTERPOLATION_DATA_CONFIGURATION, 2, reader=lambda: self.ip.free)
        reg(obj.INTERPOLATION_DATA_CONFIGURATION, 6, validator=self.ip.check_clear, on_write=self.ip.clear)
        for index, subindex in _CACHED_PARAMETERS:
            reg(index, subindex, on_write=self.invalidate_parameters)

    # ---- limits and profile parameters ---------------------------------------------
    def motion_parameters(self) -> dict[str, Any]:
        """Hook: derived motion parameters, cached until one of their objects is written
        (:meth:`invalidate_parameters`)."""
        cache = self._cache
        if cache is None:
            p = self.param
            inf = math.inf
            motor = float(p(obj.MAX_MOTOR_SPEED, default=inf))
            v_max = float(min(p(obj.MAX_PROFILE_VELOCITY, default=inf), motor))
            max_dec = float(p(obj.MAX_DECELERATION, default=inf))
            dec = max(1.0, float(min(p(obj.PROFILE_DECELERATION, default=inf), max_dec)))
            low = p(obj.SOFTWARE_POSITION_LIMIT, 1, default=0)
            high = p(obj.SOFTWARE_POSITION_LIMIT, 2, default=0)
            units = p(obj.INTERPOLATION_TIME_PERIOD, 1, default=0)
            period = units * 10.0 ** p(obj.INTERPOLATION_TIME_PERIOD, 2, default=-3)
            cache = self._cache = {
                'motor_speed': motor,
                'max_velocity': v_max,
                'profile_velocity': min(float(p(obj.PROFILE_VELOCITY, default=inf)), v_max),
                'acceleration': max(1.0, float(min(p(obj.PROFILE_ACCELERATION, default=inf),
                                                   p(obj.MAX_ACCELERATION, default=inf)))),
                'deceleration': dec,
                'quick_stop_deceleration': max(1.0, float(p(obj.QUICK_STOP_DECELERATION, default=dec))),
                'max_deceleration': max(1.0, min(max_dec, 1e12)),
                'torque_limit': float(p(obj.MAX_TORQUE, default=32767)),
                'interpolation_period': period if 1e-5 <= period <= 10.0 else None,
                'software_limits': (float(low), float(high)) if low < high else None,
                'fe_window': p(obj.FOLLOWING_ERROR_WINDOW, default=0xFFFFFFFF),
                'fe_timeout': p(obj.FOLLOWING_ERROR_TIMEOUT, default=0) / 1000.0,
            }
        return cache

    def invalidate_parameters(self, value: Any = None) -> None:
        """A parameter object changed: derive the motion parameters again when next needed."""
        self._cache = None

    def max_velocity(self) -> float:
        return self.motion_parameters()['max_velocity']

    def profile_velocity(self) -> float:
        return self.motion_parameters()['profile_velocity']

    def profile_acceleration(self) -> float:
        return self.motion_parameters()['acceleration']

    def profile_deceleration(self) -> float:
        return self.motion_parameters()['deceleration']

    def torque_limit(self) -> float:
        return self.motion_parameters()['torque_limit']

    def interpolation_period(self) -> float:
        """0x60C2 (units * 10^index s); without a usable 0x60C2 the drive's cycle (0x1006 or measured)."""
        period = self.motion_parameters()['interpolation_period']
        return period if period is not None else self.drive.cycle_period()

    def _software_limits(self) -> tuple[float, float] | None:
        return self.motion_parameters()['software_limits']

    def limit_target(self, target: float) -> float:
        """A position target inside the software limits 0x607D (bit 11 while clamped)."""
        limits = self._software_limits()
        self._limited = False
        if limits is not None and not limits[0] <= target <= limits[1]:
            self._limited = True
            return clamp(target, *limits)
        return target

    def standstill(self) -> bool:
        return self.dv == 0.0 and abs(self.v) < STANDSTILL

    def torque_demand(self) -> float:
        if self.mode_impl.torque_controlled and self.state in ENERGISED and self._stop is None:
            return self.dtorque
        return self.torque

    def shift_position(self, delta: float) -> None:
        """Redefine the position (homing): every position of this axis moves by ``delta``."""
        self.p += delta
        self.dp += delta
        self.switch_position += delta
        if self._stepping:
            self._step_shift += delta  # the step's start demand moves along

    @staticmethod
    def _check_ip_submode(value: int) -> None:
        if value != 0:  # linear interpolation only
            raise SdoAbortedError(ABORT_VALUE_RANGE)

    # ---- modes -----------------------------------------------------------------------
    def supports(self, code: int) -> bool:
        if code == Mode.NO_MODE:
            return True
        if code not in IMPLEMENTED_MODES:
            return False
        supported = self._values.get(self.key(obj.SUPPORTED_DRIVE_MODES), self.declared_modes)
        if supported is None:
            return True
        return bool(supported >> SUPPORT_BITS[Mode(code)] & 1)

    def check_mode(self, code: int) -> None:
        """Hook: validate a write of 0x6060 (abort 0x06090030 for a mode the axis lacks)."""
        if code != self.mode_impl.code and not self.supports(code):
            raise SdoAbortedError(ABORT_VALUE_RANGE)

    def mode_for(self, code: int) -> OpMode:
        """Hook: a fresh mode object for ``code`` (device models may bring their own modes)."""
        return make_mode(code)

    def set_mode(self, code: int) -> None:
        """Hook: 0x6060 written (and accepted). Default: the mode changes at once."""
        self.switch_mode(code)

    def switch_mode(self, code: int) -> None:
        """Make ``code`` the running mode now (0x6061 shows it)."""
        if code == self.mode_impl.code:
            return
        self.mode_impl = self.mode_for(code)
        if self.state is State.OPERATION_ENABLED:
            self._enter_mode()

    def _enter_mode(self) -> None:
        if not self.mode_impl.torque_controlled:
            self.dtorque = 0.0
        self.mode_impl.enter(self)

    # ---- statusword --------------------------------------------------------------------
    def compute_statusword(self) -> int:
        """0x6041 now (the reader behind SDO and TPDO)."""
        state = self.state
        sw = statusword_bits_for(state) | SW_REMOTE
        if state in VOLTAGE_STATES:
            sw |= SW_VOLTAGE_ENABLED
        if self.ip.overflows:
            sw |= SW_WARNING
        if state is State.OPERATION_ENABLED:
            if self.halted or (self._stop is not None and self._stop.reason == 'halt'):
                sw |= self.mode_impl.status_bits(self) & ~SW_TARGET_REACHED
                if self.standstill():
                    sw |= SW_TARGET_REACHED
            else:
                sw |= self.mode_impl.status_bits(self)
        elif state is State.QUICK_STOP_ACTIVE and self.standstill():
            sw |= SW_TARGET_REACHED
        if self._limited or self._at_limit():
            sw |= SW_INTERNAL_LIMIT
        return sw

    def _at_limit(self) -> bool:
        limits = self._software_limits()
        return limits is not None and not limits[0] < self.dp < limits[1] and not self.mode_impl.torque_controlled

    # ---- controlword and the state machine ---------------------------------------------
    def on_controlword(self, cw: int) -> None:
        """Hook: 0x6040 written: the device control commands and the mode's bits 4..6, 8."""
        prev, self.controlword = self.controlword, cw
        state = self.state
        if state is State.FAULT:
            if cw & CW_FAULT_RESET and not prev & CW_FAULT_RESET:
                self._fault_reset()
            return
        if state in (State.FAULT_REACTION_ACTIVE, State.NOT_READY_TO_SWITCH_ON) or cw & CW_FAULT_RESET:
            return
        disable_voltage = not cw & CW_ENABLE_VOLTAGE
        quick_stop = not disable_voltage and not cw & CW_QUICK_STOP
        low = cw & (CW_SWITCH_ON | CW_ENABLE_VOLTAGE | CW_QUICK_STOP | CW_ENABLE_OPERATION)
        shutdown = low & 0x07 == 0x06
        switch_on = low == 0x07
        enable = low == 0x0F
        if state is State.SWITCH_ON_DISABLED:
            if shutdown:
                self._goto(State.READY_TO_SWITCH_ON)  # 2
        elif state is State.READY_TO_SWITCH_ON:
            if disable_voltage or quick_stop:
                self._goto(State.SWITCH_ON_DISABLED)  # 7
            elif switch_on:
                self._goto(State.SWITCHED_ON)  # 3
            elif enable:
                self._goto(State.SWITCHED_ON)  # 3 + 4
                self._goto(State.OPERATION_ENABLED)
        elif state is State.SWITCHED_ON:
            if disable_voltage or quick_stop:
                self._goto(State.SWITCH_ON_DISABLED)  # 10
            elif shutdown:
                self._goto(State.READY_TO_SWITCH_ON)  # 6
            elif enable:
                self._goto(State.OPERATION_ENABLED)  # 4
        elif state is State.OPERATION_ENABLED:
            self._in_operation_enabled(prev, cw, disable_voltage, quick_stop, shutdown, switch_on, enable)
        elif state is State.QUICK_STOP_ACTIVE:
            if disable_voltage:
                self._goto(State.SWITCH_ON_DISABLED)  # 12
            elif enable and self._quick_stop_option() >= 5:
                self._goto(State.OPERATION_ENABLED)  # 16

    def _in_operation_enabled(self, prev: int, cw: int, disable_voltage: bool, quick_stop: bool,
                              shutdown: bool, switch_on: bool, enable: bool) -> None:
        pending = self._stop is not None and self._stop.reason in ('disable_operation', 'shutdown')
        if disable_voltage:
            self._goto(State.SWITCH_ON_DISABLED)  # 9
        elif quick_stop:
            self._quick_stop()  # 11
        elif shutdown and not pending:
            self._ramp_or_go(self.param(obj.SHUTDOWN_OPTION, default=0), 'shutdown', State.READY_TO_SWITCH_ON)  # 8
        elif switch_on and not pending:
            self._ramp_or_go(self.param(obj.DISABLE_OPERATION_OPTION, default=0), 'disable_operation',
                             State.SWITCHED_ON)  # 5
        elif enable:
            if pending:  # enable operation again during a disable ramp: keep running
                self._stop = None
                self._enter_mode()
            self._update_halt(cw)
            if self._stop is None and self.state is State.OPERATION_ENABLED:
                self.mode_impl.on_controlword(self, prev, cw)

    def _update_halt(self, cw: int) -> None:
        halt = bool(cw & CW_HALT)
        if halt == self.halted:
            return
        self.halted = halt
        if halt:
            option = self.param(obj.HALT_OPTION, default=1)
            self._begin_stop(_Stop('halt', self._ramp_deceleration(option if option in (1, 2, 3, 4) else 1), None))
        elif self._stop is not None and self._stop.reason == 'halt':
            self._stop = None
            self.mode_impl.resume(self)

    def _begin_stop(self, stop: _Stop) -> None:
        """Start a stop ramp from the demand, or from the motor's actual motion when the two
        have parted (beyond the following error window): brake the motor, not a set-point
        it never reached."""
        window = self.motion_parameters()['fe_window']
        if window != 0xFFFFFFFF and abs(self.dp - self.p) > window:
            self.dp, self.dv = self.p, self.v
        self._stop = stop

    def _ramp_or_go(self, option: int, reason: str, then: State) -> None:
        if option == 1:
            self._begin_stop(_Stop(reason, self._ramp_deceleration(1), then))
        else:
            self._goto(then)

    def _quick_stop_option(self) -> int:
        option = self.param(obj.QUICK_STOP_OPTION, default=2)
        return option if 0 <= option <= 8 else 2

    def _quick_stop(self) -> None:
        option = self._quick_stop_option()
        self._goto(State.QUICK_STOP_ACTIVE)
        if option == 0:
            self._goto(State.SWITCH_ON_DISABLED)  # disable drive function: coast, 12 at once
            return
        kind = option if option <= 4 else option - 4
        self._begin_stop(_Stop('quick_stop', self._ramp_deceleration(kind),
                               State.SWITCH_ON_DISABLED if option <= 4 else None))

    def _ramp_deceleration(self, kind: int) -> float:
        """1 slow-down ramp, 2 quick-stop ramp, 3/4 current/voltage limit (max deceleration)."""
        parameters = self.motion_parameters()
        if kind == 1:
            return parameters['deceleration']
        if kind == 2:
            return parameters['quick_stop_deceleration']
        return parameters['max_deceleration']

    def _goto(self, state: State) -> None:
        old, self.state = self.state, state
        if state is State.OPERATION_ENABLED:
            self._stop = None
            self.halted = bool(self.controlword & CW_HALT)
            if old is not State.QUICK_STOP_ACTIVE:
                self.dp, self.dv = self.p, self.v
            self._enter_mode()
            if self.halted:
                self.halted = False
                self._update_halt(self.controlword)
            self._fe_time, self.fe_active = 0.0, False
        elif state not in ENERGISED:
            self._stop = None
            self.halted = False
        self.on_transition(old, state)

    def on_transition(self, old: State, new: State) -> None:
        """Hook: the device state went from ``old`` to ``new`` (may be equal), reactions done."""

    def enter_state(self, state: State) -> None:
        """Go to ``state`` now, by the drive's own decision (e.g. an error reaction of a drive
        without a Fault state), with the transition's usual effects."""
        self._goto(state)

    def brake(self, reason: str, deceleration: float, then: State | None = None) -> None:
        """Start a stop ramp (``deceleration`` counts/s^2) from the present demand, named ``reason``:
        the mode stops driving the demand; at standstill ``then`` is entered, or (None) the axis
        stays stopped in its state until :meth:`release_brake` or a state change."""
        self._begin_stop(_Stop(reason, deceleration, then))

    def release_brake(self) -> None:
        """End a stop ramp started by :meth:`brake`: in Operation Enabled the mode starts again
        from the present demand."""
        if self._stop is not None:
            self._stop = None
            if self.state is State.OPERATION_ENABLED:
                self._enter_mode()

    @property
    def braking(self) -> str | None:
        """The reason of the running (or finished, still holding) stop ramp, None without one."""
        return None if self._stop is None else self._stop.reason

    # ---- faults -------------------------------------------------------------------------
    def fault(self, code: int, manufacturer: bytes = b'', persistent: bool = False, emit: bool = True) -> None:
        """Fault: 0x603F = code, EMCY (unless ``emit`` is False), fault reaction 0x605E."""
        self.fault_code = code & 0xFFFF
        if persistent:
            self.persistent_fault, self.persistent_code = True, self.fault_code
        self.drive.emcy.error(code, f'axis{self.slot}', manufacturer, emit=emit)
        if self.state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            return
        option = self.param(obj.FAULT_REACTION_OPTION, default=2)
        energised = self.state in ENERGISED
        self._goto(State.FAULT_REACTION_ACTIVE)
        if not energised or option == 0 or not 0 <= option <= 4:
            self._goto(State.FAULT)  # nothing to stop, or coast
            return
        self._begin_stop(_Stop('fault', self._ramp_deceleration(option), State.FAULT))

    def acknowledge_fault(self) -> bool:
        """A fault reset from another source than controlword bit 7 (e.g. a vendor's
        acknowledge object): as the bit 7 edge. True if the axis left Fault."""
        if self.state is not State.FAULT:
            return False
        self._fault_reset()
        return self.state is not State.FAULT

    def _fault_reset(self) -> None:
        if self.persistent_fault or self.drive.fault_cause_persists(self):
            return
        self.fault_code = 0
        self.fe_active = False
        self._goto(State.SWITCH_ON_DISABLED)  # 15
        self.drive.emcy.clear(f'axis{self.slot}')

    # ---- life cycle ---------------------------------------------------------------------
    def reset(self) -> None:
        """Application reset (power-on, NMT reset node): back to Not Ready To Switch On."""
        self.state = State.NOT_READY_TO_SWITCH_ON
        self.controlword = 0
        self.fault_code = 0
        self.halted = False
        self._stop = None
        self.fe_active, self._fe_time, self._limited = False, 0.0, False
        self.mode_impl = self.mode_for(self._values.get(self.key(obj.MODES_OF_OPERATION), Mode.NO_MODE))
        self.ip.reset()
        self.dp, self.dv, self.dtorque = self.p, self.v, 0.0
        self._cache = None
        self.load_boot_values()

    def load_boot_values(self) -> None:
        """Hook: what the drive takes from its dictionary only at power-on and reset node
        (the generic axis reads every parameter live)."""

    def boot(self) -> None:
        """Transition 1 (automatic); a persistent fault cause faults the axis again at once."""
        if self.state is State.NOT_READY_TO_SWITCH_ON:
            self._goto(State.SWITCH_ON_DISABLED)
        if self.persistent_fault:
            self.fault(self.persistent_code)

    # ---- time ---------------------------------------------------------------------------
    def on_sync(self) -> None:
        if self.state is State.OPERATION_ENABLED and self._stop is None:
            self.mode_impl.on_sync(self)

    def advance(self, dt: float, sync: bool) -> None:
        """Step demand and plant over ``dt`` s; then limits, following error, stop ramps."""
        self.sync_driven = sync
        if dt <= 0.0:
            return
        d0, v0 = self.dp, self.v
        state = self.state
        mode = self.mode_impl
        torque_driven = False
        if self._stop is not None:
            self.dp, self.dv = stop_step(self.dp, self.dv, self._stop.deceleration, dt)
        elif state is State.OPERATION_ENABLED:
            self._stepping, self._step_shift = True, 0.0
            mode.step(self, dt)
            self._stepping = False
            d0 += self._step_shift
            torque_driven = mode.torque_controlled
        limits = self._software_limits()
        if limits is not None and not torque_driven and (self.dp <= limits[0] and self.dv <= 0
                                                         or self.dp >= limits[1] and self.dv >= 0):
            self.dp, self.dv = clamp(self.dp, *limits), 0.0
        v_max = self.motion_parameters()['motor_speed']
        if state in ENERGISED and torque_driven:
            limit = self.torque_limit()
            self.dtorque = clamp(self.dtorque, -limit, limit)
            self.p, self.v = torque_drive(self.p, self.v, self.dtorque, dt, self.inertia, self.friction, v_max)
            self.dp, self.dv = self.p, self.v
        elif state in ENERGISED:
            a_max = max_acceleration(self.torque_limit(), self.v, self.inertia, self.friction)
            self.p, self.v = lag_follow(self.p, self.v, d0, self.dp, dt, self.lag, v_max, a_max)
        else:
            self.p, self.v = torque_drive(self.p, self.v, 0.0, dt, self.inertia, self.friction, v_max)
            self.dp, self.dv = self.p, self.v
        limit = self.torque_limit()
        self.torque = clamp(motor_torque((self.v - v0) / dt, self.v, self.inertia, self.friction), -limit, limit)
        if state is State.OPERATION_ENABLED and self._stop is None:
            mode.post_step(self, dt)
        self._check_following_error(dt)
        stop = self._stop
        if stop is not None and not stop.finished and self.dv == 0.0:
            stop.settling += dt  # the ramp ends when the motor, not only the demand, stands still
            if abs(self.v) < STANDSTILL or stop.settling > STOP_SETTLE_MAX:
                stop.finished = True
                if stop.then is not None:
                    self._goto(stop.then)

    def _check_following_error(self, dt: float) -> None:
        if self.state not in (State.OPERATION_ENABLED, State.QUICK_STOP_ACTIVE) \
                or not self.mode_impl.position_controlled:
            self._fe_time = 0.0
            return
        parameters = self.motion_parameters()
        window = parameters['fe_window']
        if window == 0xFFFFFFFF or abs(self.dp - self.p) <= window:
            self._fe_time = 0.0
            self.fe_active = False
            return
        self._fe_time += dt
        if self._fe_time > parameters['fe_timeout']:
            self.fe_active = True
            self.fault(EMCY_FOLLOWING_ERROR)

    # ---- inspection (tests) ------------------------------------------------------------
    @property
    def mode(self) -> int:
        """Modes of operation display (0x6061)."""
        return self.mode_impl.code

    @property
    def position(self) -> int:
        return wrap_int32(self.p)

    @property
    def velocity(self) -> int:
        return wrap_int32(self.v)

    @property
    def following_error(self) -> int:
        return wrap_int32(self.dp - self.p)

    @property
    def demand_position(self) -> int:
        return wrap_int32(self.dp)

    @property
    def statusword(self) -> int:
        with self.drive.lock:
            return self.compute_statusword()
