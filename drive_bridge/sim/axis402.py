"""One simulated CiA 402 axis: its objects, modes, faults, limits and life cycle, and the hooks
a family's axis overrides. Its parts: the state machine with its stop ramps and statusword
(:mod:`~drive_bridge.sim.devicecontrol`) and the control function with the following error
(:mod:`~drive_bridge.sim.controlloop`); its motion parameters are derived in
:mod:`~drive_bridge.sim.axisparams`.

Choices where CiA 402 leaves room (those of the state machine and the stop ramps:
:mod:`~drive_bridge.sim.devicecontrol`; a master must cope with all of them on real drives):

- Fault reset fails (stays in Fault) while the cause persists: a persistent injected fault
  or a lost master heartbeat.
- In torque modes, halt and quick stop brake the load by velocity control.
- Position values persist over NMT resets and power cycles (absolute encoder).
- Statusword bit 11 (internal limit active) while a target was clamped to or the demand
  stands at a software limit 0x607D (limits active when min < max).
"""
from __future__ import annotations

from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import SUPPORT_BITS, Mode
from drive_bridge.cia402.statemachine import State
from drive_bridge.sim.axisparams import CACHED_PARAMETERS, derive_motion_parameters
from drive_bridge.sim.controlloop import STANDSTILL, ControlLoop
from drive_bridge.sim.devicecontrol import ENERGISED, DeviceControl, StopRamp
from drive_bridge.sim.interfaces import AxisDrive
from drive_bridge.sim.ipbuffer import IpBuffer
from drive_bridge.sim.motion import clamp, wrap_int32
from drive_bridge.sim.opmodes import IMPLEMENTED_MODES, OpMode, make_mode
from drive_bridge.sim.store import key

ABORT_VALUE_RANGE = 0x06090030
TORQUE_DEMAND = 0x6074


class Axis402:
    """The axis in ``slot`` of a simulated drive; its objects sit at index + 0x800 * slot.

    Hooks a drive family's axis overrides (the defaults are the behaviour described above):

    - :meth:`register_objects` -- the axis' dynamic objects (extend: call super() first);
    - :meth:`derive_motion_parameters` -- derived motion parameters (ramps, limits, windows);
    - :meth:`load_boot_values` -- what the drive reads only at power-on / reset node;
    - :meth:`supports`, :meth:`check_mode`, :meth:`set_mode`, :meth:`mode_for` -- which modes,
      when a mode change takes effect, and the mode objects;
    - :meth:`on_controlword` -- a written controlword;
    - :meth:`on_transition` -- after every device state transition;
    - :meth:`compute_statusword`, :meth:`param`, :meth:`reset`, :meth:`advance`;

    and a drive acknowledges its faults by other means through :meth:`acknowledge_fault`; a
    family whose error reactions are not the Fault state acts through :meth:`enter_state`,
    :meth:`brake` and :meth:`release_brake`. A family's axis reads and writes the drive's object
    values through :attr:`values` (keys by :meth:`key`), never through a private member.
    """

    def __init__(self, drive: AxisDrive, slot: int, options: dict[str, Any]) -> None:
        self.drive = drive
        self.slot = slot
        self.values = drive.store.values  # the drive's object values (for a vendor axis too)
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
        self._limited = False
        self.ip = IpBuffer(lambda: int(self.param(obj.INTERPOLATION_DATA_CONFIGURATION, 1, default=16)))
        self.control = DeviceControl(self)
        self.loop = ControlLoop(self)
        self._cache: dict[str, Any] | None = None
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
        value = self.values.get(self.key(index, subindex), default)
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
        for index, subindex in CACHED_PARAMETERS:
            reg(index, subindex, on_write=self.invalidate_parameters)

    # ---- limits and profile parameters ---------------------------------------------
    def motion_parameters(self) -> dict[str, Any]:
        """The derived motion parameters, cached until one of their objects is written
        (:meth:`invalidate_parameters`)."""
        cache = self._cache
        if cache is None:
            cache = self._cache = self.derive_motion_parameters()
        return cache

    def derive_motion_parameters(self) -> dict[str, Any]:
        """Hook: the motion parameters from the axis' objects (extend: update super()'s)."""
        return derive_motion_parameters(self.param)

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

    def software_limits(self) -> tuple[float, float] | None:
        return self.motion_parameters()['software_limits']

    def limit_target(self, target: float) -> float:
        """A position target inside the software limits 0x607D (bit 11 while clamped)."""
        limits = self.software_limits()
        self._limited = False
        if limits is not None and not limits[0] <= target <= limits[1]:
            self._limited = True
            return clamp(target, *limits)
        return target

    def standstill(self) -> bool:
        return self.dv == 0.0 and abs(self.v) < STANDSTILL

    def torque_demand(self) -> float:
        if self.mode_impl.torque_controlled and self.state in ENERGISED and self.control.stop is None:
            return self.dtorque
        return self.torque

    def shift_position(self, delta: float) -> None:
        """Redefine the position (homing): every position of this axis moves by ``delta``."""
        self.p += delta
        self.dp += delta
        self.switch_position += delta
        self.loop.shifted(delta)

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
        supported = self.values.get(self.key(obj.SUPPORTED_DRIVE_MODES), self.declared_modes)
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
            self.enter_mode()

    def enter_mode(self) -> None:
        """Start the running mode from the present demand (Operation Enabled entered, a mode
        switched, a stop ended)."""
        if not self.mode_impl.torque_controlled:
            self.dtorque = 0.0
        self.mode_impl.enter(self)

    # ---- statusword --------------------------------------------------------------------
    def compute_statusword(self) -> int:
        """0x6041 now (the reader behind SDO and TPDO)."""
        return self.control.statusword(self._limited or self._at_limit())

    def _at_limit(self) -> bool:
        limits = self.software_limits()
        return limits is not None and not limits[0] < self.dp < limits[1] and not self.mode_impl.torque_controlled

    # ---- controlword and the state machine (DeviceControl) ---------------------------------
    def on_controlword(self, cw: int) -> None:
        """Hook: 0x6040 written: the device control commands and the mode's bits 4..6, 8."""
        prev, self.controlword = self.controlword, cw
        self.control.on_controlword(prev, cw)

    def on_transition(self, old: State, new: State) -> None:
        """Hook: the device state went from ``old`` to ``new`` (may be equal), reactions done."""

    def enter_state(self, state: State) -> None:
        """Go to ``state`` now, by the drive's own decision (e.g. an error reaction of a drive
        without a Fault state), with the transition's usual effects."""
        self.control.goto(state)

    def brake(self, reason: str, deceleration: float, then: State | None = None) -> None:
        """Start a stop ramp (``deceleration`` counts/s^2) from the present demand, named ``reason``:
        the mode stops driving the demand; at standstill ``then`` is entered, or (None) the axis
        stays stopped in its state until :meth:`release_brake` or a state change."""
        self.control.begin_stop(StopRamp(reason, deceleration, then))

    def release_brake(self) -> None:
        """End a stop ramp started by :meth:`brake`: in Operation Enabled the mode starts again
        from the present demand."""
        self.control.release()

    @property
    def braking(self) -> str | None:
        """The reason of the running (or finished, still holding) stop ramp, None without one."""
        stop = self.control.stop
        return None if stop is None else stop.reason

    # ---- faults -------------------------------------------------------------------------
    def fault(self, code: int, manufacturer: bytes = b'', persistent: bool = False, emit: bool = True) -> None:
        """Fault: 0x603F = code, EMCY (unless ``emit`` is False), fault reaction 0x605E."""
        self.fault_code = code & 0xFFFF
        if persistent:
            self.persistent_fault, self.persistent_code = True, self.fault_code
        self.drive.emcy.error(code, f'axis{self.slot}', manufacturer, emit=emit)
        if self.state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            return
        self.control.fault_reaction()

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
        self.control.goto(State.SWITCH_ON_DISABLED)  # 15
        self.drive.emcy.clear(f'axis{self.slot}')

    # ---- life cycle ---------------------------------------------------------------------
    def reset(self) -> None:
        """Application reset (power-on, NMT reset node): back to Not Ready To Switch On."""
        self.state = State.NOT_READY_TO_SWITCH_ON
        self.controlword = 0
        self.fault_code = 0
        self.halted = False
        self.control.stop = None
        self.fe_active, self.loop.fe_time, self._limited = False, 0.0, False
        self.mode_impl = self.mode_for(self.values.get(self.key(obj.MODES_OF_OPERATION), Mode.NO_MODE))
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
            self.control.goto(State.SWITCH_ON_DISABLED)
        if self.persistent_fault:
            self.fault(self.persistent_code)

    # ---- time ---------------------------------------------------------------------------
    def on_sync(self) -> None:
        if self.state is State.OPERATION_ENABLED and self.control.stop is None:
            self.mode_impl.on_sync(self)

    def advance(self, dt: float, sync: bool) -> None:
        """Step demand and plant over ``dt`` s; then limits, following error, stop ramps."""
        self.sync_driven = sync
        if dt <= 0.0:
            return
        self.loop.step(dt)

    def restart_following_error(self) -> None:
        """Operation Enabled entered: the following error is timed afresh."""
        self.loop.fe_time, self.fe_active = 0.0, False

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
