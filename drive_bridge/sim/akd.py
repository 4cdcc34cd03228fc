"""A simulated Kollmorgen AKD (family ``akd``): the generic CiA 402 drive with the AKD's
own rules where a master can observe them (manual rev. F as summarised in
shared/drives/akd.md; numbers in brackets are its sections).

Interpolated position mode (0x6060 = 7), enabled by controlword bit 4 (statusword bit 12):

- PVT (0x60C0 = -2) [5.3, 5.8]: a point is taken once 0x60C1 subs 1 (absolute position,
  counts), 2 (time in ms to reach it from the previous point) and 3 (velocity at the point,
  counts/s, times 0x204C:1 / 0x204C:2) have all been written since the last point, by
  RPDO or SDO. RPDOs received between two SYNCs are applied at the SYNC in COB-ID order
  (the manual's map: 0x301 = position + time, 0x401 = velocity). The drive runs a cubic
  Hermite from its current point to the next over that time; the first segment of a motion
  starts at the actual position (with the demand velocity, 0 at rest) at the SYNC that
  brought the point; a point with time 0 ends the motion: the axis stops at the last
  position (its own position and velocity fields are ignored) and statusword bit 10 is set
  at standstill.
- Buffer [5.5]: 0x60C4:1 = 10, of which 9 places are usable; a point occupies its place
  until the axis reaches it (the point being approached counts), so 0x60C4:2 reads 9 when
  empty, 8 while one segment runs and nothing is queued, 0 when full.
- n704 overflow [5.6]: a point arriving while the buffer is full is dropped; warning n704,
  EMCY 0x8584 (once per occurrence: not again while the warning stays).
- n705 underflow [5.6]: the running segment ends, no point follows and no end point came:
  warning n705, EMCY 0x8585; the axis brakes from the segment's end velocity to standstill
  with the controlled-stop ramp 0x3440:1 CS.DEC and holds there, still enabled. A new point
  starts a new motion from the actual position.
- Warnings (the manual does not say how they are reset): statusword bit 7 and 0x1002 bit 8
  while any is active; they clear when a point is accepted into the buffer, when the buffer
  is cleared (0x60C4:6 = 0) and when the axis leaves interpolated position mode or
  Operation Enabled. No EMCY is sent when a warning clears. A warning's EMCY carries the
  error register as it is (faults only) and category 1.
- Linear (0x60C0 = 0) [5.7]: only 0x60C1:1, one point per SYNC, reached linearly over the
  interpolation period 0x60C2; 0x60C4:5 accepts only 1; an empty buffer holds the last point
  (no warning); statusword bit 10 is never set (the manual's example shows 0x1237 at rest).
- 0x60C0 = -1 ("reserved") is refused (0x06090030); writing the sub-mode empties the buffer.
- 0x60C2 [5.4]: a new period takes effect once both sub-indices have been written; a pair
  that is not a whole number of ms is refused at its second write (0x06090030) and both must
  be written again. Power-on: 1 ms.
- Controlword bit 4 falling, a halt, a quick stop, a buffer clear: the running segment is
  abandoned and the axis brakes (profile / DRV.DEC ramp; quick stop: CS.DEC). Queued points
  are kept on bit 4 falling and on a halt (released, the axis restarts toward the point it
  was approaching, over that point's full time); they are dropped on a quick stop, on
  leaving Operation Enabled and on a mode change.

Other quirks [10]:

- 0x6502 = 0x65 (pp, pv, hm, ip), yet 0x6060 accepts 1, 3, 4, 6, 7, 8; every other value,
  CSV (9) and CST (10) included, is refused with 0x06090030 [4.6].
- A mode change takes effect at the drive's next cycle (the next SYNC, or its own 10 ms
  clock without SYNC): 0x6061 confirms it, a master must wait for it [4.6].
- Statusword bit 9 (remote) follows FBUS.REMOTE (:meth:`SimAkd.set_remote`); while it is 0
  the controlword is stored but not obeyed [4.3, 10.3].
- No option codes 0x605A-0x605E [4.4]: quick stop brakes on CS.DEC and stays in Quick Stop
  Active (bit 2 set again resumes, transition 16) and cancels the set-points [4.1] (0x60FF
  and 0x6071 read 0, a PP target and the IP buffer are dropped); disable operation ramps
  (profile / DRV.DEC ramp) then switches off; shutdown and disable voltage switch off at
  once; halt brakes on the profile ramp; a fault reaction brakes on CS.DEC. 0x6083/0x6084 = 0 (their default)
  mean DRV.ACC 0x3501 / DRV.DEC 0x3522; 0x609A = 0 means DRV.ACC; the in-position window is
  MT.TPOSWND 0x35C6; 0x6065 = 0 switches following-error monitoring off (F439, 0x8611).
- Expedited SDO downloads whose size differs from the object are accepted [10.15, 12]: more
  bytes than the object are truncated (the rest ignored); fewer are zero- or sign-extended,
  unless a byte beyond the indicated size is not zero, in which case the object's own length
  is read from the frame (the manual's ``2B 8F 60 01 00 00 10 00`` then sets 0x608F:1 to
  2^20, the value the manual says it writes). Segmented transfers must match the size.
- NMT [2.2]: start, stop, reset node, reset communication. Enter Pre-Operational (0x80) is
  not one of the AKD's commands and is ignored (an NMT command cannot be refused).
- PDOs [2.4, 10.12]: transmission types 0..240 and 255 only (241..254 refused with
  0x06090030); RPDO type n applies the data at every n-th SYNC (0: at the next); mapping
  is refused in OPERATIONAL (0x08000022, "map before NMT start"); before that the mapping
  and the COB-ID of a valid PDO may be changed directly, as the manual's examples do
  (§7.2.1.8, §7.2.2.1). Event-driven TPDO1..4 are filtered by the change masks 0x2014-0x2017.
- 0x1016 has one entry [2.8]; a lost heartbeat or node guarding (RTR on 0x700 + node,
  toggle bit, monitoring from the first RTR, time 0x100C x 0x100D [2.7]) raises F129:
  EMCY 0x8130, the axis brakes to standstill (fault reaction) and stays in Fault until the
  master is back and the fault is reset [10.16].
- FBUS.PARAM04 (0x36E8) = 1: with the axis enabled in ip or csp, three missing SYNC periods
  (0x60C2) raise F125, EMCY 0x8780 [1.6].
- EMCY frames [2.6]: byte 3 ("category") is 1 in every error or warning frame, 0 in the
  reset frame; bytes 4..7 are 0. 0x1003 keeps 10 entries.
- 0x1010:1 "save" (0x65766173) makes the present values the power-on values; 0x1011:1
  "load" (0x64616F6C) reloads the saved drive parameters (0x2000 and up); other values are
  refused with 0x08000020; both read 1. Software limits 0x607D take effect at the next
  power-on or NMT reset node [10.14].
- Units: the simulated drive is set up with position user units = counts, so 0x6063 = 0x6064
  and 0x606C is in counts/s; the manual's "0x606C in rpm over PDO" is reproduced only with
  the simulation option ``velocity_pdo_rpm: 1`` (the manual's own PDO example, §7.2.1.5,
  shows 0x1AABA6 for a 0x4000 set-point, which is neither).
"""
from __future__ import annotations

import logging
import math
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import can
import canopen
from canopen.objectdictionary import datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import (CW_OMS_4, SW_OMS_13, SW_OMS_12, SW_REMOTE, SW_TARGET_REACHED,
                                              SW_WARNING, State)
from drive_bridge.model import NodeConfig
from drive_bridge.sim.axis402 import ENERGISED, Axis402
from drive_bridge.sim.drive402 import SimDrive402
from drive_bridge.sim.emcy import EmcyProducer
from drive_bridge.sim.motion import Segment, stop_step, wrap_int32
from drive_bridge.sim.nmt import HEARTBEAT_BASE, NmtCommand, NmtState, addressed_command
from drive_bridge.sim.opmodes import Homing, OpMode, make_mode
from drive_bridge.sim.options import AXIS_OPTIONS, SLAVE_OPTIONS, OptionSpec
from drive_bridge.sim.pdo import COB_INVALID, Pdo, PdoEngine
from drive_bridge.sim.registry import register_simulator
from drive_bridge.sim.slave import EMCY_HEARTBEAT
from drive_bridge.sim.store import key

logger = logging.getLogger(__name__)

ABORT_INVALID_VALUE = 0x06090030
ABORT_STATE = 0x08000022
ABORT_NOT_STORED = 0x08000020

EMCY_PVT_OVERFLOW = 0x8584  # n704
EMCY_PVT_UNDERFLOW = 0x8585  # n705
EMCY_SYNC_LOST = 0x8780  # F125
CATEGORY = b'\x01'  # EMCY byte 3 in error and warning frames

PVT = -2
LINEAR = 0
MODES = frozenset({Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY, Mode.PROFILE_TORQUE, Mode.HOMING,
                   Mode.INTERPOLATED_POSITION, Mode.CYCLIC_SYNC_POSITION})
HOMING_METHODS = frozenset({1, 2, 8, 12, 17, 18, 24, 28, 33, 34, 35})
# the AKD has no option codes 0x605A..0x605E; its fixed behaviour in CiA terms
FIXED_OPTION_CODES = {obj.QUICK_STOP_OPTION: 6, obj.SHUTDOWN_OPTION: 0, obj.DISABLE_OPERATION_OPTION: 1,
                      obj.HALT_OPTION: 1, obj.FAULT_REACTION_OPTION: 2}

MANUFACTURER_STATUS = 0x1002
STORE_PARAMETERS = 0x1010
RESTORE_PARAMETERS = 0x1011
GUARD_TIME = 0x100C
LIFE_TIME_FACTOR = 0x100D
CHANGE_MASKS = 0x2014  # TPDO1; 0x2015..0x2017 for TPDO2..4
PV_SCALING = 0x204C
CS_DEC = 0x3440
DRV_ACC = 0x3501
DRV_DEC = 0x3522
IN_POSITION_WINDOW = 0x35C6
SYNC_SUPERVISION = 0x36E8  # FBUS.PARAM04
POSITION_INCREMENTS = 0x6063
POSITION_WINDOW = 0x6067
ENCODER_RESOLUTION = 0x608F
SIGNATURE_SAVE = 0x65766173
SIGNATURE_LOAD = 0x64616F6C

AKD_OPTIONS: dict[str, OptionSpec] = {
    **SLAVE_OPTIONS,
    **AXIS_OPTIONS,
    # the generic defaults are for 2^16 counts per revolution; the AKD counts 2^20
    'inertia': replace(AXIS_OPTIONS['inertia'], default=2e-7),
    'friction': replace(AXIS_OPTIONS['friction'], default=1e-6),
    'velocity_pdo_rpm': OptionSpec('velocity_pdo_rpm', int, 0,
                                   '1: 0x606C is sent in rpm by PDO (manual §6.6), 0: counts/s as over SDO',
                                   0, 1),
}


def _abort(code: int) -> SdoAbortedError:
    return SdoAbortedError(code)


# ---- EMCY ------------------------------------------------------------------------------
class AkdEmcy(EmcyProducer):
    """EMCY with the AKD's byte 3 ("category") = 1, and warnings (nXXX) that are sent but do
    not enter the error register."""

    def error(self, code: int, source: str = 'device', manufacturer: bytes = b'',
              transient: bool = False, emit: bool = True) -> None:
        super().error(code, source, manufacturer or CATEGORY, transient, emit)

    def warning(self, code: int) -> None:
        self._push_history(code)
        self._emit(code, self.register, CATEGORY)


# ---- PDO rules ---------------------------------------------------------------------------
class AkdPdoEngine(PdoEngine):
    """The AKD's PDO rules on top of CiA 301's (see the module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.operational: Callable[[], bool] = lambda: False
        self.pdo_readers: dict[int, Callable[[], Any]] = {}  # values a TPDO sends differently from SDO

    def validate(self, index: int, subindex: int, value: int) -> None:
        pdo = self._by_index[index]
        if index == pdo.mapping and self.operational():
            raise _abort(ABORT_STATE)  # "PDO mapping must be done before NMT start"
        if index == pdo.comm and subindex == 2 and not (value <= 240 or value == 255):
            raise _abort(ABORT_INVALID_VALUE)
        super().validate(index, subindex, value)

    def _locked(self, pdo: Pdo, cob: int) -> bool:
        return self.operational() and not cob & COB_INVALID

    def _getter(self, k: int, var: Any) -> Callable[[], Any]:
        reader = self.pdo_readers.get(k)
        return reader if reader is not None else super()._getter(k, var)

    def apply_latched(self) -> None:
        """At SYNC: RPDOs due at this SYNC (type n: every n-th), in COB-ID order, all
        stored before any reacts."""
        items: list[tuple[int, Any]] = []
        for cob in sorted(self._rx_by_cob):
            pdo = self._rx_by_cob[cob]
            if not pdo.synchronous:
                continue
            pdo.sync_count += 1
            if pdo.trans_type and pdo.sync_count < pdo.trans_type:
                continue
            pdo.sync_count = 0
            if pdo.latched is not None:
                items += self._decode(pdo, pdo.latched)
                pdo.latched = None
        if items:
            self._write_many(items)

    def _has_changed(self, pdo: Pdo, data: bytes) -> bool:
        last = pdo.last_data
        if last is None or not pdo.transmit or pdo.number > 4:
            return data != last
        values = self._store.values
        index = CHANGE_MASKS + pdo.number - 1
        mask = values.get(key(index, 1), 0xFFFFFFFF) | values.get(key(index, 2), 0xFFFFFFFF) << 32
        changed = int.from_bytes(data, 'little') ^ int.from_bytes(last, 'little')
        return bool(changed & mask) or len(data) != len(last)


# ---- interpolation buffer and modes --------------------------------------------------------
@dataclass(frozen=True)
class PvtPoint:
    position: int  # counts (absolute)
    time_ms: int  # to reach it from the previous point; 0 ends the motion (PVT)
    velocity: int  # counts/s at the point, before the 0x204C scaling


class AkdIpBuffer:
    """The interpolation buffer: 0x60C4:1 places, one of them never usable."""

    overflows = 0  # warnings are the axis' business (kept for Axis402's statusword)

    def __init__(self, size: Callable[[], int]) -> None:
        self._size = size
        self.points: deque[PvtPoint] = deque()
        self.access = True

    def __len__(self) -> int:
        return len(self.points)

    def __bool__(self) -> bool:
        return bool(self.points)

    @property
    def capacity(self) -> int:
        return max(0, self._size() - 1)

    @property
    def free(self) -> int:
        """0x60C4:2: free places."""
        return max(0, self.capacity - len(self.points))

    @property
    def head(self) -> PvtPoint:
        return self.points[0]

    def popleft(self) -> PvtPoint:
        return self.points.popleft()

    def reset(self) -> None:
        self.points.clear()
        self.access = True


@dataclass
class Hermite:
    """Cubic Hermite from (p0, v0) to (p1, v1) over ``duration`` s."""

    p0: float
    v0: float
    p1: float
    v1: float
    duration: float
    elapsed: float = 0.0

    @property
    def position(self) -> float:
        T = self.duration
        s = self.elapsed / T
        s2, s3 = s * s, s * s * s
        return ((2 * s3 - 3 * s2 + 1) * self.p0 + (s3 - 2 * s2 + s) * T * self.v0
                + (-2 * s3 + 3 * s2) * self.p1 + (s3 - s2) * T * self.v1)

    @property
    def velocity(self) -> float:
        T = self.duration
        s = self.elapsed / T
        return ((6 * s * s - 6 * s) * (self.p0 - self.p1) / T + (3 * s * s - 4 * s + 1) * self.v0
                + (3 * s * s - 2 * s) * self.v1)


class AkdInterpolation(OpMode):
    """Interpolated position mode of the AKD: linear or PVT after 0x60C0 (module docstring)."""

    code = Mode.INTERPOLATED_POSITION

    def __init__(self) -> None:
        self.active = False
        self.linear: Segment | None = None
        self.cubic: Hermite | None = None
        self.moving = False  # a PVT motion runs: its end without a next point is an underflow
        self.brake = 0.0  # deceleration while no segment runs (0: the profile ramp)
        self.reached = False  # the end-of-motion point was reached (bit 10 at standstill)

    def enter(self, ax: Axis402) -> None:
        self.active = bool(ax.controlword & CW_OMS_4)
        self.abort(0.0)
        self.reached = False

    def abort(self, brake: float) -> None:
        """Leave the running segment; brake with ``brake`` (0: the profile ramp)."""
        self.linear = self.cubic = None
        self.moving = False
        self.brake = brake

    def on_controlword(self, ax: Axis402, prev: int, cw: int) -> None:
        active = bool(cw & CW_OMS_4)
        if self.active and not active:
            self.abort(0.0)
        self.active = active

    def resume(self, ax: Axis402) -> None:
        self.abort(0.0)

    def on_sync(self, ax: Axis402) -> None:
        if not self.active:
            return
        if ax.pvt:  # type: ignore[attr-defined]
            if self.cubic is None:
                self._start(ax)
        else:
            self._consume_linear(ax)

    def step(self, ax: Axis402, dt: float) -> None:
        if ax.pvt:  # type: ignore[attr-defined]
            self._step_pvt(ax, dt)
        else:
            self._step_linear(ax, dt)

    # -- linear ---------------------------------------------------------------------------
    def _consume_linear(self, ax: Axis402) -> None:
        if ax.ip:
            point = ax.ip.popleft()  # type: ignore[attr-defined]
            self.linear = Segment(ax.dp, ax.limit_target(float(point.position)), ax.interpolation_period())

    def _step_linear(self, ax: Axis402, dt: float) -> None:
        if self.active and not ax.sync_driven and (self.linear is None or self.linear.done):
            self._consume_linear(ax)  # no SYNC: the drive's own clock paces the buffer
        if self.linear is None:
            ax.dp, ax.dv = stop_step(ax.dp, ax.dv, ax.profile_deceleration(), dt)
            return
        ax.dp = self.linear.advance(dt)
        ax.dv = self.linear.slope

    # -- PVT ------------------------------------------------------------------------------
    def _start(self, ax: Axis402) -> None:
        """First segment of a motion: from the actual position."""
        if not ax.ip:
            return
        ax.dp = ax.p
        self.moving = True
        self._continue(ax, ax.p, ax.dv)

    def _continue(self, ax: Axis402, p: float, v: float) -> None:
        """The segment after (p, v): toward the buffer's head, or the end, or an underflow."""
        buffer = ax.ip
        if buffer:
            point = buffer.head  # type: ignore[attr-defined]
            if point.time_ms == 0:
                buffer.popleft()  # type: ignore[attr-defined]
                self.moving, self.reached, self.brake = False, True, 0.0
                ax.dv = 0.0  # stop at the last position
                return
            velocity = ax.pvt_velocity(point.velocity)  # type: ignore[attr-defined]
            self.cubic = Hermite(p, v, float(point.position), velocity, point.time_ms / 1000.0)
            self.reached = False
            return
        if self.moving:
            self.moving = False
            self.brake = ax.quick_stop_deceleration()  # type: ignore[attr-defined]
            ax.warn(EMCY_PVT_UNDERFLOW)  # type: ignore[attr-defined]

    def _step_pvt(self, ax: Axis402, dt: float) -> None:
        if self.active and self.cubic is None and not ax.sync_driven:
            self._start(ax)  # no SYNC: the drive's own clock starts the motion
        remaining = dt
        while remaining > 0.0 and self.cubic is not None:
            segment = self.cubic
            used = min(remaining, segment.duration - segment.elapsed)
            segment.elapsed += used
            remaining -= used
            if segment.elapsed >= segment.duration - 1e-12:
                ax.dp, ax.dv = segment.p1, segment.v1
                self.cubic = None
                ax.ip.popleft()  # type: ignore[attr-defined]  # the point is reached: its place is free
                self._continue(ax, segment.p1, segment.v1)
            else:
                ax.dp, ax.dv = segment.position, segment.velocity
        if remaining > 0.0:
            ax.dp, ax.dv = stop_step(ax.dp, ax.dv, self.brake or ax.profile_deceleration(), remaining)

    def status_bits(self, ax: Axis402) -> int:
        bits = SW_OMS_12 if self.active else 0
        if ax.fe_active:
            bits |= SW_OMS_13
        if self.reached and self.cubic is None and ax.standstill():
            bits |= SW_TARGET_REACHED
        return bits


class AkdHoming(Homing):
    """Homing as the generic model, but no target-reached bit before the first run (the
    manual reads 0x0237 after enabling in homing mode), and 0x1002 learns 'homed'."""

    def status_bits(self, ax: Axis402) -> int:
        if self.phase == 'idle':
            return 0
        if self.phase == 'done':
            ax.homed = True  # type: ignore[attr-defined]
        return super().status_bits(ax)


# ---- the axis ------------------------------------------------------------------------------
class AkdAxis(Axis402):
    """The AKD's one axis (see the module docstring)."""

    def __init__(self, drive: SimDrive402, slot: int, options: dict[str, Any]) -> None:
        self.warnings: set[int] = set()
        self.homed = False
        self._pending_mode: int | None = None
        self._period = 0.001
        self._period_written: set[int] = set()
        self._record_written: set[int] = set()
        self._boot_limits: tuple[float, float] | None = None
        super().__init__(drive, slot, options)
        self._load_boot_values()

    # -- objects ------------------------------------------------------------------------------
    def _register(self) -> None:
        super()._register()
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
            reg(index, subindex, on_write=self._invalidate)
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

    def _parameters(self) -> dict[str, Any]:
        cache = self._cache
        if cache is None:
            cache = super()._parameters()
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
        return self._parameters()['quick_stop_deceleration']

    @property
    def pvt(self) -> bool:
        return self._values.get(self.key(obj.INTERPOLATION_SUB_MODE), LINEAR) == PVT

    def pvt_velocity(self, velocity: int) -> float:
        numerator = self._values.get(key(PV_SCALING, 1), 1)
        denominator = self._values.get(key(PV_SCALING, 2), 1) or 1
        return float(velocity) * numerator / denominator

    # -- interpolation objects ------------------------------------------------------------------
    @staticmethod
    def _check_submode(value: int) -> None:
        if value not in (LINEAR, PVT):
            raise _abort(ABORT_INVALID_VALUE)  # -1 is reserved

    def _on_submode(self, value: int) -> None:
        self._cancel_interpolation()

    def _check_record_size(self, value: int) -> None:
        if not self.pvt and value != 1:
            raise _abort(ABORT_INVALID_VALUE)  # linear interpolation: one sub-index per record

    def _on_record(self, sub: int) -> None:
        values, k = self._values, self.key
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
            raise _abort(ABORT_INVALID_VALUE)

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
        units = value if sub == 1 else self._values[self.key(obj.INTERPOLATION_TIME_PERIOD, 1)]
        index = value if sub == 2 else self._values[self.key(obj.INTERPOLATION_TIME_PERIOD, 2)]
        period_ms = units * 10.0 ** (index + 3)
        if period_ms < 1.0 - 1e-9 or abs(period_ms - round(period_ms)) > 1e-6:
            self._period_written.clear()
            raise _abort(ABORT_INVALID_VALUE)  # only whole multiples of 1 ms

    def _on_period(self, sub: int) -> None:
        self._period_written.add(sub)
        if self._period_written == {1, 2}:
            self._period_written.clear()
            self._period = self._committed_period()
            self._invalidate()

    def _committed_period(self) -> float:
        units = self._values.get(self.key(obj.INTERPOLATION_TIME_PERIOD, 1), 1)
        index = self._values.get(self.key(obj.INTERPOLATION_TIME_PERIOD, 2), -3)
        return units * 10.0 ** index if units else 0.001

    @staticmethod
    def _check_homing_method(value: int) -> None:
        if value not in HOMING_METHODS:
            raise _abort(ABORT_INVALID_VALUE)

    # -- modes ------------------------------------------------------------------------------------
    def _make_mode(self, code: int) -> OpMode:
        if code == Mode.INTERPOLATED_POSITION:
            return AkdInterpolation()
        if code == Mode.HOMING:
            return AkdHoming()
        return make_mode(code)

    def supports(self, code: int) -> bool:
        return code in MODES

    def _check_mode(self, code: int) -> None:
        if code not in MODES:
            raise _abort(ABORT_INVALID_VALUE)

    def _set_mode(self, code: int) -> None:
        """Takes effect at the drive's next cycle (0x6061 then shows it)."""
        self._pending_mode = None if code == self.mode_impl.code else code

    def _apply_pending_mode(self) -> None:
        code, self._pending_mode = self._pending_mode, None
        if code is None or code == self.mode_impl.code:
            return
        if isinstance(self.mode_impl, AkdInterpolation):
            self._cancel_interpolation()
        Axis402._set_mode(self, code)

    # -- state machine and statusword -------------------------------------------------------------
    def _on_controlword(self, cw: int) -> None:
        if not self.drive.remote:  # type: ignore[attr-defined]
            self.controlword = cw  # another channel has control (FBUS.REMOTE = 0)
            return
        super()._on_controlword(cw)

    def _goto(self, state: State) -> None:
        old = self.state
        super()._goto(state)
        if old is State.OPERATION_ENABLED and state is not State.OPERATION_ENABLED:
            self._cancel_interpolation()
        if state is State.QUICK_STOP_ACTIVE:  # "setpoints are cancelled" (digital set-points)
            for index in (obj.TARGET_VELOCITY, obj.TARGET_TORQUE):
                if self.key(index) in self._values:
                    self._values[self.key(index)] = 0

    def compute_statusword(self) -> int:
        sw = super().compute_statusword() & ~SW_WARNING
        if self.warnings:
            sw |= SW_WARNING
        if not self.drive.remote:  # type: ignore[attr-defined]
            sw &= ~SW_REMOTE
        return sw

    # -- life cycle -----------------------------------------------------------------------------------
    def _load_boot_values(self) -> None:
        """What the drive reads at power-on / reset node: software limits and the IP period."""
        low = self._values.get(self.key(obj.SOFTWARE_POSITION_LIMIT, 1), 0)
        high = self._values.get(self.key(obj.SOFTWARE_POSITION_LIMIT, 2), 0)
        self._boot_limits = (float(low), float(high)) if low < high else None
        self._period = self._committed_period()
        self._period_written.clear()
        self._cache = None

    def reset(self) -> None:
        self._pending_mode = None
        self.homed = False
        self._record_written.clear()
        self.warnings.clear()
        super().reset()
        self._load_boot_values()

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
        if self._stop is not None and not self._stop.finished:
            bits |= 1 << 31
        return bits


# ---- node guarding -------------------------------------------------------------------------------
class _Guarding:
    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.toggle = 0
        self.last: float | None = None  # monotonic time of the last RTR (None: not started)
        self.lost = False


# ---- the drive -------------------------------------------------------------------------------------
@register_simulator('akd')
class SimAkd(SimDrive402):
    """A simulated Kollmorgen AKD; see the module docstring for what it reproduces."""

    OPTIONS = AKD_OPTIONS
    PDO_ENGINE = AkdPdoEngine
    EMCY_PRODUCER = AkdEmcy
    AXIS_CLASS = AkdAxis

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        self.remote = True
        self._guard = _Guarding()
        self._guard_listener: Callable[[can.Message], None] | None = None
        self._sdo_frame: bytes | None = None
        self._sync_lost = False
        super().__init__(node, options=options)
        pdo: AkdPdoEngine = self.pdo  # type: ignore[assignment]
        pdo.operational = lambda: self._nmt is NmtState.OPERATIONAL
        if self.options['velocity_pdo_rpm'] and key(obj.VELOCITY_ACTUAL, 0) in self.store:
            pdo.pdo_readers[key(obj.VELOCITY_ACTUAL, 0)] = self._velocity_rpm
        store = self.store

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if key(index, subindex) in store:
                self.register_object(index, subindex, **hooks)

        reg(MANUFACTURER_STATUS, reader=lambda: self.axes[0].manufacturer_status())  # type: ignore[attr-defined]
        reg(STORE_PARAMETERS, 1, reader=lambda: 1, validator=self._signature(SIGNATURE_SAVE),
            on_write=lambda value: self._save())
        reg(RESTORE_PARAMETERS, 1, reader=lambda: 1, validator=self._signature(SIGNATURE_LOAD),
            on_write=lambda value: self._load())
        for sub in (1, 2):
            reg(PV_SCALING, sub, validator=self._check_pv_scaling)

    @property
    def axis_akd(self) -> AkdAxis:
        return self.axes[0]  # type: ignore[return-value]

    # -- inspection and test switches ----------------------------------------------------------------
    def set_remote(self, on: bool = True) -> None:
        """FBUS.REMOTE: False = another channel (WorkBench, Telnet) has control (bit 9 = 0)."""
        with self._lock:
            self.remote = bool(on)
            self.pdo.poll_events()

    @property
    def warnings(self) -> list[int]:
        """EMCY codes of the active warnings (n704 = 0x8584, n705 = 0x8585)."""
        with self._lock:
            return sorted(self.axis_akd.warnings)

    # -- objects -------------------------------------------------------------------------------------
    @staticmethod
    def _signature(expected: int) -> Callable[[int], None]:
        def check(value: int) -> None:
            if value != expected:
                raise _abort(ABORT_NOT_STORED)
        return check

    def _save(self) -> None:
        """DRV.NVSAVE: the present values become the power-on values."""
        for k in self.store.variables:
            self.store.defaults[k] = self.store.values[k]
        for index in (STORE_PARAMETERS, RESTORE_PARAMETERS):
            if key(index, 1) in self.store:
                self.store.defaults[key(index, 1)] = 1

    def _load(self) -> None:
        """DRV.NVLOAD: the saved drive parameters (0x2000 and up) replace the present ones."""
        self.store.reset(0x2000, 0xFFFF)
        for axis in self.axes:
            axis._invalidate()

    @staticmethod
    def _check_pv_scaling(value: int) -> None:
        if value == 0:
            raise _abort(ABORT_INVALID_VALUE)

    def _velocity_rpm(self) -> int:
        increments = self.store.values.get(key(ENCODER_RESOLUTION, 1), 2 ** 20) or 2 ** 20
        revolutions = self.store.values.get(key(ENCODER_RESOLUTION, 2), 1)
        return int(round(self.axes[0].v * 60.0 * revolutions / increments))

    # -- SDO: expedited downloads of another size than the object's -------------------------------------
    def _on_sdo_request(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self._lock:
            self._sdo_frame = bytes(data)
            try:
                super()._on_sdo_request(can_id, data, timestamp)
            finally:
                self._sdo_frame = None

    def _sdo_write(self, index: int, subindex: int, data: bytes, check_writable: bool) -> None:
        frame = self._sdo_frame
        if frame is not None and len(frame) == 8 and frame[0] & 0xE2 == 0x22 \
                and int.from_bytes(frame[1:3], 'little') == index and frame[3] == subindex:
            data = self._fit_expedited(index, subindex, bytes(data), frame)
        super()._sdo_write(index, subindex, data, check_writable)

    def _fit_expedited(self, index: int, subindex: int, data: bytes, frame: bytes) -> bytes:
        try:
            var = self.store.find(index, subindex)
        except SdoAbortedError:
            return data  # the normal path answers with the right abort
        if var.data_type not in dt.INTEGER_TYPES:
            return data
        size, given = len(var) // 8, len(data)
        if given == size:
            return data
        if given > size:
            return data[:size]  # the unused bytes are ignored
        if size <= 4 and any(frame[4 + given:4 + size]):
            return frame[4:4 + size]  # the object's own length (the manual's 0x608F:1 example)
        signed = var.data_type in dt.SIGNED_TYPES
        return int.from_bytes(data, 'little', signed=signed).to_bytes(size, 'little', signed=signed)

    # -- NMT, heartbeat, node guarding, SYNC supervision ----------------------------------------------
    def _on_nmt(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if addressed_command(bytes(data), self.node_id) is NmtCommand.ENTER_PRE_OPERATIONAL:
            return  # not one of the AKD's four NMT commands
        super()._on_nmt(can_id, data, timestamp)

    def _reset(self, application: bool) -> None:
        self._guard.reset()
        self._sync_lost = False
        super()._reset(application)

    def power_on(self) -> None:
        with self._lock:
            self._guard.reset()
            self._sync_lost = False
        super().power_on()

    def _on_heartbeat_lost(self, node: int) -> None:
        self._communication_lost('heartbeat')

    def _communication_lost(self, source: str) -> None:
        """F129: EMCY 0x8130, then the fault reaction (brake to standstill, Fault)."""
        self.emcy.error(EMCY_HEARTBEAT, source)
        for axis in self.axes:
            axis.fault(EMCY_HEARTBEAT, emit=False)

    def fault_cause_persists(self, axis: Axis402) -> bool:
        return self._consumer.is_lost() or self._guard.lost

    def attach(self, network: canopen.Network) -> None:
        super().attach(network)
        notifier = getattr(network, 'notifier', None)
        if notifier is not None:  # RTR frames never reach canopen's subscribers
            self._guard_listener = self._on_frame
            notifier.add_listener(self._guard_listener)

    def detach(self) -> None:
        network, listener = self._network, self._guard_listener
        self._guard_listener = None
        if network is not None and listener is not None and getattr(network, 'notifier', None) is not None:
            try:
                network.notifier.remove_listener(listener)
            except ValueError:
                pass
        super().detach()

    def _on_frame(self, msg: can.Message) -> None:
        if not msg.is_remote_frame or msg.arbitration_id != HEARTBEAT_BASE + self.node_id:
            return
        try:
            with self._lock:
                if self.faults.muted or self._nmt in (NmtState.OFF, NmtState.INITIALISING):
                    return
                guard = self._guard
                self._send(HEARTBEAT_BASE + self.node_id, bytes([guard.toggle | int(self._nmt)]))
                guard.toggle ^= 0x80
                guard.last = time.monotonic()
                if guard.lost:
                    guard.lost = False
                    self.emcy.clear('guarding')
        except Exception:  # never let an exception stop the shared Notifier
            logger.exception('%s: node guarding reply failed', self.name)

    def _on_tick(self) -> None:
        super()._on_tick()
        with self._lock:
            if self._nmt in (NmtState.OFF, NmtState.INITIALISING):
                return
            now = time.monotonic()
            guard = self._guard
            life_ms = self.store.values.get(key(GUARD_TIME, 0), 0) * self.store.values.get(key(LIFE_TIME_FACTOR, 0), 0)
            changed = False
            if life_ms and guard.last is not None and not guard.lost and now - guard.last > life_ms / 1000.0:
                guard.lost = True
                self._communication_lost('guarding')
                changed = True
            changed |= self._supervise_sync(now)
            if changed:
                self.pdo.poll_events()

    def _supervise_sync(self, now: float) -> bool:
        """F125 after three missing SYNC periods (FBUS.PARAM04 = 1); True when it was raised."""
        if not self.store.values.get(key(SYNC_SUPERVISION, 0), 0) or not math.isfinite(self._last_sync):
            self._sync_lost = False
            return False
        axis = self.axis_akd
        if axis.state is not State.OPERATION_ENABLED or axis.mode not in (Mode.INTERPOLATED_POSITION,
                                                                           Mode.CYCLIC_SYNC_POSITION):
            return False
        if now - self._last_sync <= 3 * axis.interpolation_period() + 0.005:
            self._sync_lost = False
            return False
        if self._sync_lost:
            return False
        self._sync_lost = True
        axis.fault(EMCY_SYNC_LOST)
        return True
