"""The AKD's one axis: the generic CiA 402 axis with the AKD's parameters, modes and
interpolation objects (package docstring; manual sections in brackets).

- Fixed option codes (no 0x605A..0x605E) [4.4]; 0x6083/0x6084 = 0 mean DRV.ACC / DRV.DEC,
  0x609A = 0 means DRV.ACC, CS.DEC is the quick-stop and fault ramp, the in-position window
  is MT.TPOSWND, 0x6065 = 0 switches following-error monitoring off.
- 0x6060 accepts 1, 3, 4, 6, 7, 8 only; a mode change takes effect at the drive's next cycle [4.6].
- While FBUS.REMOTE = 0 the controlword is stored but not obeyed [4.3, 10.3].
- Quick stop cancels the set-points (0x60FF, 0x6071 read 0) [4.1]; leaving Operation Enabled,
  a quick stop and a mode change drop the interpolation buffer.
- 0x60C2 takes effect once both sub-indices are written, whole ms only [5.4]; software limits
  0x607D and the IP period are read at power-on / reset node [10.14].
"""
from __future__ import annotations

from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import SW_REMOTE, SW_WARNING, State
from drive_bridge.sim.akd.homing import AkdHoming
from drive_bridge.sim.akd.objects import (
    ABORT_INVALID_VALUE,
    CS_DEC,
    DRV_ACC,
    DRV_DEC,
    EMCY_PVT_OVERFLOW,
    FIXED_OPTION_CODES,
    HOMING_METHODS,
    IN_POSITION_WINDOW,
    LINEAR,
    MODES,
    POSITION_INCREMENTS,
    POSITION_WINDOW,
    PV_SCALING,
    PVT,
)
from drive_bridge.sim.akd.pvt import AkdInterpolation, AkdIpBuffer, PvtPoint
from drive_bridge.sim.axis402 import Axis402
from drive_bridge.sim.devicecontrol import ENERGISED
from drive_bridge.sim.interfaces import AxisDrive
from drive_bridge.sim.motion import wrap_int32
from drive_bridge.sim.opmodes import Homing, OpMode, make_mode
from drive_bridge.sim.store import key


class AkdAxis(Axis402):
    """The AKD's one axis (module docstring)."""

    ip: AkdIpBuffer  # type: ignore[assignment]  # the AKD's buffer holds PVT points

    def __init__(self, drive: AxisDrive, slot: int, options: dict[str, Any]) -> None:
        self.warnings: set[int] = set()
        self.homed = False
        self._pending_mode: int | None = None
        self._period = 0.001
        self._period_written: set[int] = set()
        self._record_written: set[int] = set()
        self._boot_limits: tuple[float, float] | None = None
        super().__init__(drive, slot, options)

    # -- objects ------------------------------------------------------------------------------
    def register_objects(self) -> None:
        super().register_objects()
        self.ip = AkdIpBuffer(lambda: int(self.param(obj.INTERPOLATION_DATA_CONFIGURATION, 1, default=10)))
        d = self.drive

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if key(index, subindex) in d.store:
                d.register_object(index, subindex, **hooks)

        record, config = obj.INTERPOLATION_DATA_RECORD, obj.INTERPOLATION_DATA_CONFIGURATION
        reg(POSITION_INCREMENTS, reader=lambda: wrap_int32(self.p))
        reg(obj.INTERPOLATION_SUB_MODE, validator=self._check_submode, on_write=self._on_submode)
        for sub in (1, 2, 3):
            reg(record, sub, on_write=lambda value, sub=sub: self._on_record(sub))
        reg(config, 2, reader=lambda: self.ip.free)
        reg(config, 5, validator=self._check_record_size)
        reg(config, 6, validator=self._check_clear, on_write=self._on_clear)
        for sub in (1, 2):
            reg(obj.INTERPOLATION_TIME_PERIOD, sub, validator=lambda value, sub=sub: self._check_period(sub, value),
                on_write=lambda value, sub=sub: self._on_period(sub))
        for index, subindex in ((DRV_ACC, 0), (DRV_DEC, 0), (CS_DEC, 1), (IN_POSITION_WINDOW, 0)):
            reg(index, subindex, on_write=self.invalidate_parameters)
        reg(obj.HOMING_METHOD, validator=self._check_homing_method)

    def param(self, index: int, subindex: int = 0, default: Any = None) -> Any:
        if subindex == 0:
            if index in FIXED_OPTION_CODES:
                return FIXED_OPTION_CODES[index]
            if index == POSITION_WINDOW:
                return super().param(IN_POSITION_WINDOW, 0, default)
            if index == obj.HOMING_ACCELERATION:
                return super().param(index, 0, default) or self.profile_acceleration()
        return super().param(index, subindex, default)

    def derive_motion_parameters(self) -> dict[str, Any]:
        cache = super().derive_motion_parameters()
        p = self.param
        acc = p(obj.PROFILE_ACCELERATION, default=0) or p(DRV_ACC, default=0)
        dec = p(obj.PROFILE_DECELERATION, default=0) or p(DRV_DEC, default=0)
        quick = p(CS_DEC, 1, default=0) or dec
        window = cache['fe_window']
        cache.update(acceleration=max(1.0, float(acc)), deceleration=max(1.0, float(dec)),
                     quick_stop_deceleration=max(1.0, float(quick)), max_deceleration=max(1.0, float(quick)),
                     interpolation_period=self._period, software_limits=self._boot_limits,
                     fe_window=0xFFFFFFFF if window == 0 else window)
        return cache

    def quick_stop_deceleration(self) -> float:
        return self.motion_parameters()['quick_stop_deceleration']

    @property
    def pvt(self) -> bool:
        return self.values.get(self.key(obj.INTERPOLATION_SUB_MODE), LINEAR) == PVT

    def pvt_velocity(self, velocity: int) -> float:
        numerator = self.values.get(key(PV_SCALING, 1), 1)
        denominator = self.values.get(key(PV_SCALING, 2), 1) or 1
        return float(velocity) * numerator / denominator

    # -- interpolation objects ------------------------------------------------------------------
    @staticmethod
    def _check_submode(value: int) -> None:
        if value not in (LINEAR, PVT):
            raise SdoAbortedError(ABORT_INVALID_VALUE)  # -1 is reserved

    def _on_submode(self, value: int) -> None:
        self._cancel_interpolation()

    def _check_record_size(self, value: int) -> None:
        if not self.pvt and value != 1:
            raise SdoAbortedError(ABORT_INVALID_VALUE)  # linear interpolation: one sub-index per record

    def _on_record(self, sub: int) -> None:
        values, k = self.values, self.key
        record = obj.INTERPOLATION_DATA_RECORD
        if not self.pvt:
            if sub == 1:
                self._push(PvtPoint(int(values[k(record, 1)]), 0, 0))
            return
        self._record_written.add(sub)
        if len(self._record_written) == 3:
            self._record_written.clear()
            self._push(PvtPoint(int(values[k(record, 1)]), int(values[k(record, 2)]), int(values[k(record, 3)])))

    def _push(self, point: PvtPoint) -> None:
        buffer = self.ip
        if not buffer.access:
            return
        if buffer.free <= 0:
            self.warn(EMCY_PVT_OVERFLOW)  # n704: the point is dropped
            return
        buffer.points.append(point)
        self.accepted_point()

    def accepted_point(self) -> None:
        self.warnings.clear()

    def warn(self, code: int) -> None:
        if code not in self.warnings:
            self.warnings.add(code)
            self.drive.emcy.warning(code)  # type: ignore[attr-defined]

    @staticmethod
    def _check_clear(value: int) -> None:
        if value not in (0, 1):
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    def _on_clear(self, value: int) -> None:
        if value == 0:  # clear the buffer and refuse points until 1 is written (CiA 402)
            self._cancel_interpolation()
            self.ip.access = False
        else:
            self.ip.access = True

    def _cancel_interpolation(self) -> None:
        """Buffer, partial record, warnings and the running segment go (the axis brakes)."""
        self.ip.points.clear()
        self._record_written.clear()
        self.warnings.clear()
        if isinstance(self.mode_impl, AkdInterpolation):
            self.mode_impl.abort(0.0)

    def _check_period(self, sub: int, value: int) -> None:
        if self._period_written | {sub} != {1, 2}:
            return
        units = value if sub == 1 else self.values[self.key(obj.INTERPOLATION_TIME_PERIOD, 1)]
        index = value if sub == 2 else self.values[self.key(obj.INTERPOLATION_TIME_PERIOD, 2)]
        period_ms = units * 10.0 ** (index + 3)
        if period_ms < 1.0 - 1e-9 or abs(period_ms - round(period_ms)) > 1e-6:
            self._period_written.clear()
            raise SdoAbortedError(ABORT_INVALID_VALUE)  # only whole multiples of 1 ms

    def _on_period(self, sub: int) -> None:
        self._period_written.add(sub)
        if self._period_written == {1, 2}:
            self._period_written.clear()
            self._period = self._committed_period()
            self.invalidate_parameters()

    def _committed_period(self) -> float:
        units = self.values.get(self.key(obj.INTERPOLATION_TIME_PERIOD, 1), 1)
        index = self.values.get(self.key(obj.INTERPOLATION_TIME_PERIOD, 2), -3)
        return units * 10.0 ** index if units else 0.001

    @staticmethod
    def _check_homing_method(value: int) -> None:
        if value not in HOMING_METHODS:
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    # -- modes ------------------------------------------------------------------------------------
    def mode_for(self, code: int) -> OpMode:
        if code == Mode.INTERPOLATED_POSITION:
            return AkdInterpolation()
        if code == Mode.HOMING:
            return AkdHoming()
        return make_mode(code)

    def supports(self, code: int) -> bool:
        return code in MODES

    def check_mode(self, code: int) -> None:
        if code not in MODES:
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    def set_mode(self, code: int) -> None:
        """Takes effect at the drive's next cycle (0x6061 then shows it)."""
        self._pending_mode = None if code == self.mode_impl.code else code

    def _apply_pending_mode(self) -> None:
        code, self._pending_mode = self._pending_mode, None
        if code is None or code == self.mode_impl.code:
            return
        if isinstance(self.mode_impl, AkdInterpolation):
            self._cancel_interpolation()
        self.switch_mode(code)

    # -- state machine and statusword -------------------------------------------------------------
    def on_controlword(self, cw: int) -> None:
        if not self.drive.remote:  # type: ignore[attr-defined]
            self.controlword = cw  # another channel has control (FBUS.REMOTE = 0)
            return
        super().on_controlword(cw)

    def on_transition(self, old: State, new: State) -> None:
        if old is State.OPERATION_ENABLED and new is not State.OPERATION_ENABLED:
            self._cancel_interpolation()
        if new is State.QUICK_STOP_ACTIVE:  # "setpoints are cancelled" (digital set-points)
            for index in (obj.TARGET_VELOCITY, obj.TARGET_TORQUE):
                if self.key(index) in self.values:
                    self.values[self.key(index)] = 0

    def compute_statusword(self) -> int:
        sw = super().compute_statusword() & ~SW_WARNING
        if self.warnings:
            sw |= SW_WARNING
        if not self.drive.remote:  # type: ignore[attr-defined]
            sw &= ~SW_REMOTE
        return sw

    # -- life cycle -----------------------------------------------------------------------------------
    def load_boot_values(self) -> None:
        """What the drive reads at power-on / reset node: software limits and the IP period."""
        low = self.values.get(self.key(obj.SOFTWARE_POSITION_LIMIT, 1), 0)
        high = self.values.get(self.key(obj.SOFTWARE_POSITION_LIMIT, 2), 0)
        self._boot_limits = (float(low), float(high)) if low < high else None
        self._period = self._committed_period()
        self._period_written.clear()
        self.invalidate_parameters()

    def reset(self) -> None:
        self._pending_mode = None
        self.homed = False
        self._record_written.clear()
        self.warnings.clear()
        super().reset()  # ... which loads the boot values

    def advance(self, dt: float, sync: bool) -> None:
        if self._pending_mode is not None:
            self._apply_pending_mode()
        super().advance(dt, sync)

    def manufacturer_status(self) -> int:
        """0x1002 (§4.5), the bits the simulation knows."""
        state = self.state
        bits = 1 << 29  # hardware enable input
        if not self.standstill():
            bits |= 1 << 0
        if self.homed:
            bits |= 1 << 1 | 1 << 23
        if self.standstill() and abs(self.dp - self.p) <= self.param(IN_POSITION_WINDOW, default=0):
            bits |= 1 << 3
        if self.warnings:
            bits |= 1 << 8
        if isinstance(self.mode_impl, Homing) and self.mode_impl.phase in ('search', 'creep'):
            bits |= 1 << 16
        if state in ENERGISED:
            bits |= 1 << 14
        if state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            bits |= 1 << 15
        if state is State.QUICK_STOP_ACTIVE:
            bits |= 1 << 19
        if self.control.stop is not None and not self.control.stop.finished:
            bits |= 1 << 31
        return bits
