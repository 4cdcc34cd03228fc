"""The SERVOSTAR's axis: the CiA 402 axis with the drive's state machine, statusword, modes,
units and error reactions (package docstring; sections of the facts document in brackets)."""
from __future__ import annotations

import math
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.statemachine import CW_FAULT_RESET, State
from drive_bridge.sim.axis402 import Axis402
from drive_bridge.sim.interfaces import AxisDrive
from drive_bridge.sim.opmodes import OpMode, make_mode
from drive_bridge.sim.servostar.modes import SPEED_ZERO, STAR_MODES, MotionTask, Trajectory
from drive_bridge.sim.servostar.objects import (
    ABORT_INVALID_VALUE,
    ACC,
    CW_ACKNOWLEDGE,
    DEC,
    DECSTOP,
    HOMING_METHODS,
    INTERPOLATION_PERIOD,
    JOG,
    MODES,
    MOTION_TASK,
    MOTION_TASK_PDO,
    OPMODE,
    POSITION_CONTROLLER,
    POSITION_FACTOR,
    POWER_ON_MODES,
    PRBASE,
    PROFILE_VELOCITY,
    PTBASE,
    SAMPLE,
    SETPOINT,
    SPEED_DIGITAL,
    VALUE,
    VELOCITY_FACTOR,
    VLIM,
)
from drive_bridge.sim.servostar.status import actual_value_readers, status_register, statusword
from drive_bridge.sim.servostar.units import Units, check_interpolation_period, ptbase_of_period
from drive_bridge.sim.store import key

STAGE_STATES = frozenset({State.SWITCHED_ON, State.OPERATION_ENABLED, State.QUICK_STOP_ACTIVE})
# CiA 402 option codes the SERVOSTAR lacks, as its fixed behaviour [4.3]: disable operation ramps
# down with the mode's ramp, shutdown switches the stage off at once
FIXED_OPTION_CODES = {obj.SHUTDOWN_OPTION: 0, obj.DISABLE_OPERATION_OPTION: 1, obj.HALT_OPTION: 1}
POSITION_WINDOW, POSITION_WINDOW_TIME = 0x6067, 0x6068
VELOCITY_WINDOW, VELOCITY_WINDOW_TIME = 0x606D, 0x606E
HOMING_METHOD_AS = {-1: 34, -2: 35, -3: 35}  # 6098h methods without a CiA 402 twin, as the model runs them
STANDSTILL = 1.0  # counts/s
TIMING_TOLERANCE = 0.25  # a SYNC interval off PTBASE by more than this fraction is a mismatch
SUBSTEP, MAX_SUBSTEPS = 0.0005, 200  # s, model steps in trajectory mode


class ServostarAxis(Axis402):
    """The SERVOSTAR's one axis (package docstring)."""

    def __init__(self, drive: AxisDrive, slot: int, options: dict[str, Any]) -> None:
        self.toggle = False
        self.homed = False
        self.task_active = False
        self.warnings = 0  # 0x1002 bits 0..15
        self._pending_mode: int | None = None
        self._fresh_setpoint = False
        self._latched_setpoint = 0
        self.period = 0.001  # s, PTBASE as read at boot
        self.units = Units(drive.store.values, lambda: self.star.options)
        self.trajectory_target = 0.0
        # views for tests (trajectory mode)
        self.sync_intervals: list[float] = []
        self.timing_mismatches = 0
        self.clamped_steps = 0
        self._mismatch_run = 0
        super().__init__(drive, slot, options)

    @property
    def star(self) -> Any:
        return self.drive

    # -- objects ---------------------------------------------------------------------------------------
    def register_objects(self) -> None:
        super().register_objects()
        d = self.drive

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if key(index, subindex) in d.store:
                d.register_object(index, subindex, **hooks)

        for (index, subindex), reader in actual_value_readers(self).items():
            reg(index, subindex, reader=reader)
        reg(obj.HOMING_METHOD, validator=self._check_homing_method)
        reg(MOTION_TASK, 4, on_write=self._on_trajectory_setpoint)
        reg(MOTION_TASK, 5, on_write=self._on_task_number)
        reg(MOTION_TASK, 3, on_write=self._on_task_type)
        for sub in (1, 2):
            reg(INTERPOLATION_PERIOD, sub, validator=lambda value, sub=sub: self._check_period(sub, value),
                on_write=lambda value, sub=sub: self._on_period(sub))
        reg(PRBASE, VALUE, validator=self._check_prbase)
        for index, subindex in ((ACC, VALUE), (DEC, VALUE), (DECSTOP, VALUE), (VLIM, VALUE), (VELOCITY_FACTOR, 1),
                                (VELOCITY_FACTOR, 2), (POSITION_FACTOR, 1), (POSITION_FACTOR, 2),
                                (POSITION_CONTROLLER, 8), (POSITION_CONTROLLER, 9)):
            reg(index, subindex, on_write=self.invalidate_parameters)

    # -- units (units.py) ---------------------------------------------------------------------------------
    @property
    def prbase(self) -> int:
        return self.units.prbase

    def vlim(self) -> float:
        return self.units.vlim()

    def ramp(self, time_ms: float, speed: float) -> float:
        return self.units.ramp(time_ms, speed)

    def user_to_counts(self, value: float) -> float:
        return self.units.user_to_counts(value)

    def param(self, index: int, subindex: int = 0, default: Any = None) -> Any:
        if subindex == 0 and index in FIXED_OPTION_CODES:
            return FIXED_OPTION_CODES[index]
        if subindex == 0:
            if index == obj.TARGET_POSITION:
                return super().param(index, 0, 0) / self.units.position_factor()
            if index == obj.HOME_OFFSET:
                return super().param(index, 0, 0) / self.units.position_factor()
            if index in (obj.TARGET_VELOCITY, obj.PROFILE_VELOCITY):
                return super().param(index, 0, 0) * self.units.velocity_factor()
            if index == obj.HOMING_METHOD:
                method = super().param(index, 0, 0)
                return HOMING_METHOD_AS.get(method, method)
            if index == obj.HOMING_ACCELERATION:
                speed = self.param(obj.HOMING_SPEEDS, 1, 0) or self.units.vlim()
                return self.units.ramp(super().param(index, 0, 0) or 10, speed)
            if index == POSITION_WINDOW:
                return self.units.user_to_counts(self.values.get(key(POSITION_CONTROLLER, 2), 0x4000))
            if index == VELOCITY_WINDOW:
                return SPEED_ZERO
            if index in (POSITION_WINDOW_TIME, VELOCITY_WINDOW_TIME):
                return 0
        if index == obj.HOMING_SPEEDS and subindex in (1, 2):
            return super().param(index, subindex, 0) * self.units.velocity_factor()
        return super().param(index, subindex, default)

    def derive_motion_parameters(self) -> dict[str, Any]:
        cache = super().derive_motion_parameters()
        speed_mode = self.mode_impl.code in (SPEED_DIGITAL, PROFILE_VELOCITY, JOG)
        cache.update(self.units.ramps(cache['profile_velocity'], speed_mode),
                     interpolation_period=self.period, software_limits=None, fe_window=0xFFFFFFFF,
                     torque_limit=2000.0)
        return cache

    def profile_acceleration(self) -> float:
        parameters = self.motion_parameters()
        if self.mode_impl.code == SPEED_DIGITAL:
            return parameters['speed_acceleration']
        if self.mode_impl.code == PROFILE_VELOCITY:
            return parameters['pv_acceleration']
        return parameters['acceleration']

    def profile_deceleration(self) -> float:
        parameters = self.motion_parameters()
        if self.mode_impl.code == SPEED_DIGITAL:
            return parameters['speed_deceleration']
        if self.mode_impl.code == PROFILE_VELOCITY:
            return parameters['pv_deceleration']
        return parameters['deceleration']

    @staticmethod
    def _check_homing_method(value: int) -> None:
        if value not in HOMING_METHODS:
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    def _check_prbase(self, value: int) -> None:
        if value not in (16, 20):
            raise SdoAbortedError(ABORT_INVALID_VALUE)
        self.star.check_disabled()  # "Disabled Reset"

    def _check_period(self, sub: int, value: int) -> None:
        check_interpolation_period(self.values, sub, value)

    def _on_period(self, sub: int) -> None:
        self.values[key(PTBASE, VALUE)] = ptbase_of_period(self.values)

    # -- trajectory and motion-task objects -------------------------------------------------------------
    def _on_trajectory_setpoint(self, value: int) -> None:
        self._fresh_setpoint = True

    def trajectory_setpoint(self) -> float | None:
        """At SYNC: the commanded position of the next PTBASE period (counts), None when no new
        setpoint came (absolute: the last one holds)."""
        if not self._fresh_setpoint:
            return None if self.star.options['trajectory_setpoints'] == 'relative' else self.trajectory_target
        self._fresh_setpoint = False
        value = self.values[key(MOTION_TASK, 4)] / self.units.prbase_scale()
        if self.star.options['trajectory_setpoints'] == 'relative':
            self.trajectory_target += value
        else:
            self.trajectory_target = value
        return self.trajectory_target

    def trajectory_period(self) -> float:
        return self.period

    def trajectory_clamped(self, step: float, limit: float) -> None:
        """A setpoint step beyond VLIM x PTBASE: the demand falls behind (or, with the option
        trajectory_step_check = 'error', the following error is raised at once)."""
        self.clamped_steps += 1
        if self.star.options['trajectory_step_check'] == 'error':
            self.star.following_error(self)

    def _on_task_number(self, value: int) -> None:
        self.star.start_motion_task(self, value)

    def _on_task_type(self, value: int) -> None:
        if getattr(self.star.pdo, 'applying', None) == MOTION_TASK_PDO:
            self.star.start_motion_task(self, 0)  # RPDO 34 starts the direct task 0

    def start_task(self) -> bool:
        """Start the direct motion task 0 now; False if the mode cannot run it."""
        if isinstance(self.mode_impl, MotionTask) and self.state is State.OPERATION_ENABLED and self.braking is None:
            self.mode_impl.start(self)
            return True
        return False

    def digital_setpoint(self) -> int:
        if self.star.options['digital_setpoint'] == 'enable':
            return self._latched_setpoint
        return int(self.values.get(key(SETPOINT), 0))

    # -- modes ----------------------------------------------------------------------------------------------
    def supports(self, code: int) -> bool:
        return code in MODES

    def check_mode(self, code: int) -> None:
        if code not in MODES:
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    def mode_for(self, code: int) -> OpMode:
        factory = STAR_MODES.get(code)
        return factory() if factory is not None else make_mode(code)

    def set_mode(self, code: int) -> None:
        """A mode counts once 0x6061 shows it: at the drive's next cycle at standstill [4.6]."""
        self._pending_mode = None if code == self.mode_impl.code else code

    def _apply_pending_mode(self) -> None:
        code = self._pending_mode
        if code is None or (self.state in STAGE_STATES and not self.standstill()):
            return
        self._pending_mode = None
        for index in (SETPOINT, obj.TARGET_VELOCITY):  # "the setpoint of the new mode must be set again"
            if key(index) in self.values:
                self.values[key(index)] = 0
        self._latched_setpoint = 0
        self.task_active = False
        self.switch_mode(code)
        self.invalidate_parameters()  # the ramps refer to the mode's speed

    @property
    def pending_mode(self) -> int | None:
        return self._pending_mode

    # -- state machine --------------------------------------------------------------------------------------
    @property
    def stage_enabled(self) -> bool:
        return self.state in STAGE_STATES

    def on_controlword(self, cw: int) -> None:
        prev = self.controlword
        star = self.star
        if cw & CW_ACKNOWLEDGE and not prev & CW_ACKNOWLEDGE:
            star.acknowledge()  # category 2 errors and warnings n03 / n04
        if cw & CW_FAULT_RESET:
            self.controlword = cw
            if not prev & CW_FAULT_RESET and star.fault_pending():
                star.reset_fault()  # category 1: the drive restarts
            return
        low = cw & 0x0F
        if self.state is State.SWITCH_ON_DISABLED and low in (0x07, 0x0F):
            super().on_controlword((prev & ~0x0F) | 0x06)  # 0x0007 / 0x000F directly: through 2
        if self.state is State.READY_TO_SWITCH_ON and low in (0x07, 0x0F) and not star.can_switch_on():
            self.controlword = cw
            star.enable_refused()  # transition 3 needs the hardware enable (and no fault)
            return
        super().on_controlword(cw)
        if self.state is State.OPERATION_ENABLED and low == 0x0F:
            self._latched_setpoint = int(self.values.get(key(SETPOINT), 0))  # "renewed Enable Operation"

    def on_transition(self, old: State, new: State) -> None:
        if new is State.QUICK_STOP_ACTIVE and old is not new:
            self._clear_setpoints()
        if (old in STAGE_STATES) != (new in STAGE_STATES):
            self.star.stage_changed(new in STAGE_STATES)
        if new is State.OPERATION_ENABLED and self.star.motion_blocked():
            self.error_stop()

    def _clear_setpoints(self) -> None:
        """Quick stop clears the setpoints: task number, digital setpoint, jog and homing speed [4.3]."""
        for index, sub in ((SETPOINT, 0), (obj.TARGET_VELOCITY, 0), (MOTION_TASK, 5), (0x2024, 3), (0x2024, 7)):
            if key(index, sub) in self.values:
                self.values[key(index, sub)] = 0
        self._latched_setpoint = 0
        self.task_active = False

    def error_stop(self) -> None:
        """A category 2 reaction: brake on the emergency ramp from the motor's motion, then hold;
        motion stays blocked until the acknowledge (controlword bit 11)."""
        if self.state is State.OPERATION_ENABLED and self.braking != 'error':
            self.dp, self.dv = self.p, self.v
            self.brake('error', self.units.emergency_deceleration())
        self.task_active = False

    def release(self) -> None:
        if self.braking == 'error':
            self.release_brake()

    def stage_off(self, not_ready: bool = False) -> None:
        """The output stage is switched off (hardware enable or DC link gone; ``not_ready``: a
        category 1 error, which also leaves Ready to Switch On): the state machine follows to
        Switch On Disabled, the motor is torque-free."""
        if self.state in STAGE_STATES or (not_ready and self.state is State.READY_TO_SWITCH_ON):
            self.enter_state(State.SWITCH_ON_DISABLED)
        self.task_active = False

    # -- statusword and status registers (status.py) -----------------------------------------------------
    def compute_statusword(self) -> int:
        return statusword(self, super().compute_statusword(), self.values)

    def status_register(self) -> int:
        """0x1002 (DRVSTAT)."""
        return status_register(self, self.values)

    def extended_status(self) -> int:
        """0x2070:11 for TPDO 33: digital inputs in bits 0..3 (input 1 = hardware enable), bits
        16..31 as 0x1002."""
        return self.status_register() & 0xFFFF0000 | (1 if self.star.hardware_enable else 0)

    # -- life cycle ------------------------------------------------------------------------------------
    def load_boot_values(self) -> None:
        """PTBASE and PRBASE take effect at power-on / restart only [5.1]."""
        self.period = max(1, int(self.values.get(key(PTBASE, VALUE), 4))) * SAMPLE
        self.units.prbase = int(self.values.get(key(PRBASE, VALUE), 20))
        self.invalidate_parameters()

    def reset(self) -> None:
        self._pending_mode = None
        self._fresh_setpoint = False
        self._latched_setpoint = 0
        self.toggle = self.homed = self.task_active = False
        self.warnings = 0
        self._mismatch_run = 0
        super().reset()
        saved = self.values.get(key(OPMODE, VALUE), 8)
        self.mode_impl = self.mode_for(POWER_ON_MODES.get(saved, SPEED_DIGITAL))

    def advance(self, dt: float, sync: bool) -> None:
        if self._pending_mode is not None:
            self._apply_pending_mode()
        trajectory = isinstance(self.mode_impl, Trajectory) and self.state is State.OPERATION_ENABLED
        if sync and trajectory:
            self._check_timing(dt)
        # the drive's position loop runs every 250 us: in 0xFA the model steps at most 0.5 ms, so a
        # SYNC interval longer than PTBASE shows as the dip it is, not as one averaged step
        steps = min(MAX_SUBSTEPS, math.ceil(dt / SUBSTEP)) if trajectory and dt > SUBSTEP else 1
        for _ in range(steps):
            super().advance(dt / steps, sync)
            if self.state is State.OPERATION_ENABLED and self.braking is None \
                    and self.mode_impl.position_controlled:
                self._check_pemax()

    def _check_timing(self, interval: float) -> None:
        """Trajectory mode: the SYNC interval (frame time stamps) against PTBASE [5.2]."""
        if len(self.sync_intervals) >= 1000:
            del self.sync_intervals[:500]
        self.sync_intervals.append(interval)
        if abs(interval - self.period) > TIMING_TOLERANCE * self.period:
            self.timing_mismatches += 1
            self._mismatch_run += 1
            if self._mismatch_run >= 3 and self.star.options['trajectory_timing'] == 'error':
                self.star.trajectory_error(self)
        else:
            self._mismatch_run = 0

    def following_error_counts(self) -> float:
        mode = self.mode_impl
        if isinstance(mode, Trajectory):
            return mode.following_error(self)
        return self.dp - self.p

    def _check_pemax(self) -> None:
        limit = self.values.get(key(POSITION_CONTROLLER, 3), 0)
        error = self.units.counts_to_user(self.following_error_counts())
        if limit > 0 and not math.isnan(self.p) and abs(error) > limit:
            self.star.following_error(self)
