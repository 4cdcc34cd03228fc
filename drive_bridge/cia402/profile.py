"""What the CiA 402 driver asks its drive family: the objects an axis uses, the modes it
accepts and how each is streamed, the PVT record layout, the fault reset.

``drive_bridge.families.DriveFamily`` implements this protocol with a plain CiA 402 answer for
each (:func:`standard_strategy` for the streaming); a family overrides only what its manual says
differs.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.joint.strategy import StreamStrategy

ObjectKey = tuple[int, int]


@dataclass(frozen=True)
class AxisObjects:
    """The objects one axis slot uses for actual and target values (index, subindex)."""

    position_actual: ObjectKey
    velocity_actual: ObjectKey
    effort_actual: ObjectKey
    target_position: ObjectKey
    target_velocity: ObjectKey
    target_effort: ObjectKey

    @classmethod
    def cia402(cls, slot: int) -> AxisObjects:
        """The standard objects (0x6064, 0x606C, 0x6077, 0x607A, 0x60FF, 0x6071) of a slot."""
        def at(index: int) -> ObjectKey:
            return obj.for_axis(index, slot), 0
        return cls(at(obj.POSITION_ACTUAL), at(obj.VELOCITY_ACTUAL), at(obj.TORQUE_ACTUAL),
                   at(obj.TARGET_POSITION), at(obj.TARGET_VELOCITY), at(obj.TARGET_TORQUE))


def axis_keys(slot: int, objects: AxisObjects) -> dict[str, ObjectKey]:
    """The objects of one axis slot by the names the axis uses (``objects``: its actual and
    target values, the family's answer)."""
    def at(index: int, sub: int = 0) -> ObjectKey:
        return obj.for_axis(index, slot), sub
    return {
        'controlword': at(obj.CONTROLWORD), 'statusword': at(obj.STATUSWORD),
        'mode': at(obj.MODES_OF_OPERATION), 'mode_display': at(obj.MODES_OF_OPERATION_DISPLAY),
        'supported_modes': at(obj.SUPPORTED_DRIVE_MODES), 'homing_method': at(obj.HOMING_METHOD),
        'home_offset': at(obj.HOME_OFFSET), 'homing_acceleration': at(obj.HOMING_ACCELERATION),
        'error_code': at(obj.ERROR_CODE), 'ip_submode': at(obj.INTERPOLATION_SUB_MODE),
        'position': objects.position_actual, 'velocity': objects.velocity_actual, 'torque': objects.effort_actual,
        'target_position': objects.target_position, 'target_velocity': objects.target_velocity,
        'target_torque': objects.target_effort,
        'ip_position': at(obj.INTERPOLATION_DATA_RECORD, 1), 'ip_units': at(obj.INTERPOLATION_TIME_PERIOD, 1),
        'ip_index': at(obj.INTERPOLATION_TIME_PERIOD, 2), 'ip_free': at(obj.INTERPOLATION_DATA_CONFIGURATION, 2),
        'ip_clear': at(obj.INTERPOLATION_DATA_CONFIGURATION, 6)}


@dataclass(frozen=True)
class PvtRecord:
    """Where one position-velocity-time point goes and in which units. Writes go in the
    order velocity, time, position (the drive takes the point once all parts arrived)."""

    position: ObjectKey
    time: ObjectKey
    velocity: ObjectKey
    time_unit: float  # seconds per unit of the time entry (0.001: ms)


@dataclass(frozen=True)
class FaultModel:
    """How the drive shows and clears a fault."""

    fault_state: bool = True  # CiA 402 Fault state in the statusword
    reset_bit: int = 7  # controlword bit whose rising edge resets the fault


class ProfileModes(Protocol):
    """The modes part of a profile (a family's ``ModeTraits`` record fits it)."""

    @property
    def accepted(self) -> frozenset[int] | None:
        """The modes the drive takes; None: trust 0x6502."""
        ...
    @property
    def pvt_submode(self) -> int | None:
        """The 0x60C0 code of the family's PVT interpolation; None: it has none."""
        ...


class ProfileAxes(Protocol):
    """The axes part of a profile (a family's ``AxisTraits`` record fits it)."""

    @property
    def fault_model(self) -> FaultModel: ...


class Cia402Profile(Protocol):
    """The family side of a CiA 402 axis (implemented by ``DriveFamily``). Its ``modes`` and
    ``axes`` are typed by what the axis reads of them, so the core needs not know the family's
    trait records."""

    @property
    def name(self) -> str: ...
    @property
    def modes(self) -> ProfileModes: ...
    @property
    def axes(self) -> ProfileAxes: ...

    def axis_objects(self, slot: int) -> AxisObjects: ...
    def pvt_record(self, slot: int) -> PvtRecord | None: ...
    def streaming_strategy(self, mode: int, ip_submode: int) -> StreamStrategy | None: ...
    def is_stream_fault(self, event: EmcyEvent) -> bool: ...


def standard_strategy(mode: int, ip_submode: int, pvt_submode: int | None) -> StreamStrategy | None:
    """CiA 402's own streaming per mode: cyclic position (CSP) or velocity (CSV) set-points,
    IP linear or the family's PVT sub-mode; other modes take no trajectory."""
    if mode == Mode.CYCLIC_SYNC_POSITION:
        return StreamStrategy.CYCLIC
    if mode == Mode.CYCLIC_SYNC_VELOCITY:
        return StreamStrategy.CYCLIC_VELOCITY
    if mode == Mode.INTERPOLATED_POSITION:
        pvt = pvt_submode is not None and ip_submode == pvt_submode and ip_submode != 0
        return StreamStrategy.PVT if pvt else StreamStrategy.IP_LINEAR
    return None
