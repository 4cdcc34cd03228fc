"""One motor drive object of the S120 (an axis slot): the generic CiA 402 axis with the
S120's modes, units, ramps and stop reactions (package docstring; sections in brackets).

- Modes: only VL, PV and PT; a write of 0x6060 always succeeds and reads back the written
  value (the EDS limits of 0x6060 are lifted), the mode changes at the drive's next cycle
  when it is one of the three, else the old mode stays; 0x6061 shows the mode in effect [7].
- Units [5]: the model counts p0408 x 2^p0418 increments per revolution (read at boot);
  0x60FF / 0x606C / 0x606B / 0x6069 in increments/s with an encoder (option ``encoder``), in
  rpm without; 0x6042..0x6044 in rpm; torques in per mille of r0333; 0x6063 = r0482 in
  increments (0 without an encoder).
- Ramps [4.1]: 0x6083 / 0x6084 / 0x6085 are p1082 / p1120, p1082 / p1121, p1082 / p1135 (in
  velocity units per s: writing one sets the ramp time); 0x6046 = p1080 / p1082 (rpm), 0x6048
  = p1082 (rpm) / p1120 (s); 0x6072 = p1520 in per mille of r0333; 0x6007 = p8641.
- Stops (SINAMICS OFF commands [4.2, B]): shutdown from Operation Enabled is OFF1 (ramp down on
  p1121, then Ready to Switch On), disable operation cancels the pulses (the motor coasts,
  Switched On), quick stop is OFF3 (ramp down on p1135, then Switch On Disabled), disable
  voltage is OFF2 (coast). A fault reacts with its own OFF1 / OFF2 / OFF3.
- Statusword bit 7 (warning) while an alarm of this drive object is active.
"""
from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import Any

from canopen.objectdictionary import datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import SW_WARNING, State
from drive_bridge.sim.axis402 import Axis402
from drive_bridge.sim.interfaces import AxisDrive
from drive_bridge.sim.motion import clamp, wrap_int32
from drive_bridge.sim.opmodes import OpMode
from drive_bridge.sim.s120.modes import make_s120_mode
from drive_bridge.sim.s120.objects import (
    ABORT_CONNECTION_OPTION,
    ABORT_TOO_LOW,
    EMCY_DRIVE_FAULT,
    MODES,
    POSITION_ACTUAL,
    REACTIONS,
    TORQUE_DEMAND,
    VELOCITY_SENSOR,
    VL_ACCELERATION,
    VL_ACTUAL,
    VL_DEMAND,
    VL_MIN_MAX,
    VL_TARGET,
)
from drive_bridge.sim.s120.parameters import ParameterSet

# the S120 has no 0x605A..0x605C: its fixed behaviour as CiA 402 option codes
FIXED_OPTION_CODES = {obj.SHUTDOWN_OPTION: 1, obj.DISABLE_OPERATION_OPTION: 0, obj.QUICK_STOP_OPTION: 2}
FAST = 1e12  # counts/s^2: a ramp time of 0 s
_INT_RANGES = {
    dt.UNSIGNED8: (0, 0xFF), dt.UNSIGNED16: (0, 0xFFFF), dt.UNSIGNED32: (0, 0xFFFFFFFF),
    dt.INTEGER8: (-0x80, 0x7F), dt.INTEGER16: (-0x8000, 0x7FFF), dt.INTEGER32: (-2 ** 31, 2 ** 31 - 1),
}


def motor_defaults(options: dict[str, Any]) -> dict[int, Any]:
    """Factory values of a motor drive object's parameters from the simulation options."""
    rated = float(options['rated_torque'])
    return {
        311: float(options['rated_speed']), 333: rated, 400: [9999 if options['encoder'] else 0, 0, 0],
        408: [int(options['encoder_pulses']), 0, 0], 418: [int(options['fine_resolution']), 2, 2],
        1080: 0.0, 1082: float(options['max_speed']),
        1120: float(options['ramp_up_time']), 1121: float(options['ramp_down_time']),
        1135: float(options['off3_ramp_down_time']),
        1520: float(options['torque_limit']) or 2.0 * rated, 8641: int(options['p8641']),
    }


class S120Axis(Axis402):
    """A motor drive object of the S120 in axis slot ``slot`` (module docstring)."""

    def __init__(self, drive: AxisDrive, slot: int, options: dict[str, Any]) -> None:
        self.do_number = int(options['do_numbers']) or 2 + slot
        self.encoder = bool(options['encoder'])
        self.boot_mode = int(options['mode'])
        self.parameters = ParameterSet(False, motor_defaults(options))
        self.counts_per_rev = self._resolution()
        self.warning = False  # an alarm of this drive object is active (statusword bit 7)
        self.on_acknowledged: Callable[[S120Axis], None] = lambda axis: None
        self._pending_mode: int | None = None
        self._fault_reaction = REACTIONS['OFF2']
        super().__init__(drive, slot, options)

    # -- parameters and units ---------------------------------------------------------------------
    def _resolution(self) -> int:
        return max(1, int(self.parameters.get(408)) << int(self.parameters.get(418)))

    def parameter(self, number: int, index: int = 0) -> Any:
        return self.parameters.get(number, index)

    def set_parameter(self, number: int, index: int, value: Any) -> None:
        self.parameters.set(number, index, value)
        self.invalidate_parameters()

    def rpm(self, counts_per_s: float) -> float:
        return counts_per_s * 60.0 / self.counts_per_rev

    def counts(self, rpm: float) -> float:
        return rpm * self.counts_per_rev / 60.0

    def to_bus(self, counts_per_s: float) -> int:
        """A velocity in 0x60FF / 0x606C units: increments/s with an encoder, rpm without."""
        return wrap_int32(counts_per_s if self.encoder else self.rpm(counts_per_s))

    def from_bus(self, value: float) -> float:
        return float(value) if self.encoder else self.counts(value)

    def torque_nm(self, per_mille: float) -> float:
        return per_mille * float(self.parameter(333)) / 1000.0

    def speed_target(self, code: int) -> float:
        if code == Mode.VELOCITY:
            target = self.counts(self.param(VL_TARGET, default=0))
        else:
            target = self.from_bus(self.param(obj.TARGET_VELOCITY, default=0))
        limit = self.max_velocity()
        return clamp(target, -limit, limit)

    def torque_target(self) -> float:
        return float(self.param(obj.TARGET_TORQUE, default=0))

    def param(self, index: int, subindex: int = 0, default: Any = None) -> Any:
        if subindex == 0:
            if index in FIXED_OPTION_CODES:
                return FIXED_OPTION_CODES[index]
            if index == obj.FAULT_REACTION_OPTION:
                return self._fault_reaction
        return super().param(index, subindex, default)

    def derive_motion_parameters(self) -> dict[str, Any]:
        p = self.parameter
        v_max = self.counts(float(p(1082)))

        def rate(time: float) -> float:
            return max(1.0, v_max / time) if time > 0 else FAST

        rated = float(p(333))
        return {
            'motor_speed': v_max, 'max_velocity': v_max, 'profile_velocity': v_max,
            'acceleration': rate(float(p(1120))), 'deceleration': rate(float(p(1121))),
            'quick_stop_deceleration': rate(float(p(1135))), 'max_deceleration': FAST,
            'torque_limit': 1000.0 * float(p(1520)) / rated if rated > 0 else 32767.0,
            'interpolation_period': None, 'software_limits': None, 'fe_window': 0xFFFFFFFF,
            'fe_timeout': 0.0,
        }

    # -- objects ------------------------------------------------------------------------------------
    def register_objects(self) -> None:
        super().register_objects()
        d = self.drive
        store = d.store

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if self.key(index, subindex) in store:
                d.register_object(obj.for_axis(index, self.slot), subindex, **hooks)

        # any INTEGER8 is accepted [7], and the modes run are shown, whatever limits the EDS gives
        # (the flat EDS: 0x6060 / 0x6061 3..3, 0x6502 4..4)
        for index in (obj.MODES_OF_OPERATION, obj.MODES_OF_OPERATION_DISPLAY, obj.SUPPORTED_DRIVE_MODES):
            k = self.key(index)
            if k in store:
                relaxed = copy.copy(store.variables[k])
                relaxed.min = relaxed.max = None
                store.variables[k] = relaxed
        if self.key(obj.MODES_OF_OPERATION) in store:
            store.set_default(obj.for_axis(obj.MODES_OF_OPERATION, self.slot), 0, self.boot_mode)
        reg(obj.SUPPORTED_DRIVE_MODES, reader=self.supported_modes)
        reg(POSITION_ACTUAL, reader=lambda: wrap_int32(self.p) if self.encoder else 0)
        reg(obj.VELOCITY_ACTUAL, reader=lambda: self.to_bus(self.v))
        reg(VELOCITY_SENSOR, reader=lambda: self.to_bus(self.v))
        reg(obj.VELOCITY_DEMAND, reader=lambda: self.to_bus(self.dv))
        reg(VL_DEMAND, reader=lambda: self._typed(VL_DEMAND, 0, self.rpm(self.dv)))
        reg(VL_ACTUAL, reader=lambda: self._typed(VL_ACTUAL, 0, self.rpm(self.v)))
        reg(TORQUE_DEMAND, reader=lambda: self._typed(TORQUE_DEMAND, 0, self.torque_demand()))
        reg(ABORT_CONNECTION_OPTION, reader=lambda: self.parameter(8641),
            on_write=lambda value: self.set_parameter(8641, 0, int(value)))
        for index, number in ((obj.PROFILE_ACCELERATION, 1120), (obj.PROFILE_DECELERATION, 1121),
                              (obj.QUICK_STOP_DECELERATION, 1135)):
            reg(index, reader=lambda index=index, number=number: self._ramp_read(index, number),
                validator=self._check_rate, on_write=lambda value, number=number: self._ramp_write(number, value))
        for index, sub, number in ((VL_MIN_MAX, 1, 1080), (VL_MIN_MAX, 2, 1082), (VL_ACCELERATION, 1, 1082),
                                   (VL_ACCELERATION, 2, 1120)):
            reg(index, sub, reader=lambda index=index, sub=sub, number=number: self._typed(
                index, sub, self.parameter(number)),
                on_write=lambda value, number=number: self.set_parameter(number, 0, float(value)))
        reg(obj.MAX_TORQUE, reader=lambda: self._typed(obj.MAX_TORQUE, 0, 1000.0 * self.parameter(1520) / max(
            float(self.parameter(333)), 1e-9)),
            on_write=lambda value: self.set_parameter(1520, 0, self.torque_nm(float(value))))

    def _typed(self, index: int, subindex: int, value: float) -> Any:
        """``value`` as the object's data type holds it (rounded and clamped for integers)."""
        var = self.drive.store.variables[self.key(index, subindex)]
        if var.data_type in dt.FLOAT_TYPES:
            return float(min(max(value, -3.4e38), 3.4e38))
        low, high = _INT_RANGES.get(var.data_type or 0, (-2 ** 63, 2 ** 64 - 1))
        return int(clamp(round(value) if math.isfinite(value) else math.copysign(high, value), low, high))

    def _ramp_read(self, index: int, number: int) -> Any:
        time = float(self.parameter(number))
        v_max = abs(self.to_bus(self.counts(float(self.parameter(1082)))))
        return self._typed(index, 0, v_max / time if time > 0 else math.inf)

    @staticmethod
    def _check_rate(value: float) -> None:
        if value <= 0:
            raise SdoAbortedError(ABORT_TOO_LOW)

    def _ramp_write(self, number: int, value: float) -> None:
        v_max = abs(self.to_bus(self.counts(float(self.parameter(1082)))))
        self.set_parameter(number, 0, v_max / float(value))

    def dynamic_parameter(self, number: int, index: int = 0) -> Any:
        """The value of an r-parameter of the model (window reads)."""
        if number in (61, 63):
            return self.rpm(self.v)
        if number in (62, 1170):
            return self.rpm(self.dv)
        if number == 79:
            return self.torque_nm(self.torque_demand())
        if number == 80:
            return self.torque_nm(self.torque)
        if number == 482:
            return wrap_int32(self.p) & 0xFFFFFFFF if self.encoder and index == 0 else 0
        if number == 1300:
            torque = self.mode_impl.torque_controlled
            return (22 if torque else 20) + (1 if self.encoder else 0)
        if number == 8784:
            return self.compute_statusword()
        if number == 8795:
            return self.controlword
        raise KeyError(number)

    # -- modes ----------------------------------------------------------------------------------------
    def supported_modes(self) -> int:
        """0x6502: VL (if its objects exist), PV and PT."""
        bits = 1 << 2 | 1 << 3
        if self.key(VL_TARGET) in self.drive.store:
            bits |= 1 << 1
        return bits

    def supports(self, code: int) -> bool:
        return code in MODES and (code != Mode.VELOCITY or self.key(VL_TARGET) in self.drive.store)

    def check_mode(self, code: int) -> None:
        """Every value of the data type is accepted [7]."""

    def set_mode(self, code: int) -> None:
        """Goes into p1300 in the background: the mode changes at the next cycle if the drive
        object can run it, else the old mode stays (0x6060 reads back the request anyway)."""
        self._pending_mode = code if self.supports(code) and code != self.mode_impl.code else None

    def mode_for(self, code: int) -> OpMode:
        return make_s120_mode(code)

    def advance(self, dt: float, sync: bool) -> None:
        code, self._pending_mode = self._pending_mode, None
        if code is not None:
            self.switch_mode(code)
        super().advance(dt, sync)

    # -- state machine ----------------------------------------------------------------------------------
    def compute_statusword(self) -> int:
        sw = super().compute_statusword()
        return sw | SW_WARNING if self.warning else sw

    def on_transition(self, old: State, new: State) -> None:
        if old is State.FAULT and new is not State.FAULT:
            self.on_acknowledged(self)

    def trip(self, reaction: str) -> None:
        """A SINAMICS fault of this drive object: its reaction (OFF1 / OFF2 / OFF3), then Fault."""
        self._fault_reaction = REACTIONS[reaction]
        self.fault(EMCY_DRIVE_FAULT, emit=False)

    # -- life cycle ---------------------------------------------------------------------------------------
    def reset(self) -> None:
        self._pending_mode = None
        super().reset()
        requested = self.values.get(self.key(obj.MODES_OF_OPERATION), self.boot_mode)
        self.mode_impl = self.mode_for(requested if self.supports(requested) else self.boot_mode)

    def load_boot_values(self) -> None:
        """p0408 / p0418 (the increments per revolution) take effect at boot; the position keeps
        its revolutions."""
        resolution = self._resolution()
        if resolution != self.counts_per_rev:
            scale = resolution / self.counts_per_rev
            self.p, self.dp, self.v, self.dv = self.p * scale, self.dp * scale, self.v * scale, self.dv * scale
            self.counts_per_rev = resolution
        self.invalidate_parameters()

    @property
    def speed_rpm(self) -> float:
        return self.rpm(self.v)

    @property
    def requested_mode(self) -> int:
        return int(self.values.get(self.key(obj.MODES_OF_OPERATION), 0))
