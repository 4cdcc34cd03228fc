"""What each layer of a simulated CiA 402 drive may use of the layer above it:
a mode of operation of its axis (:class:`ModeAxis`), an axis of its drive (:class:`AxisDrive`).

Declared here, below all of them, so imports run one way only:
drive402 -> axis402 -> controlloop -> devicecontrol -> opmode -> interfaces, and axis402 ->
opmodes -> the modes -> opmode (never back, not even for type hints).
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Protocol

from drive_bridge.sim.emcy import EmcyProducer
from drive_bridge.sim.ipbuffer import IpBuffer
from drive_bridge.sim.store import ObjectStore


class ModeAxis(Protocol):
    """The axis as a mode of operation sees it: demand and plant, and the axis' parameters."""

    # demand (dp, dv, dtorque) and plant (p, v, torque), counts, counts/s, per mille
    dp: float
    dv: float
    dtorque: float
    p: float
    v: float
    torque: float
    controlword: int
    halted: bool
    sync_driven: bool  # the present step was triggered by a SYNC
    fe_active: bool  # following error
    ip: IpBuffer
    switch_position: float
    homing_timeout: float

    def param(self, index: int, subindex: int = 0, default: Any = None) -> Any: ...

    def max_velocity(self) -> float: ...

    def profile_velocity(self) -> float: ...

    def profile_acceleration(self) -> float: ...

    def profile_deceleration(self) -> float: ...

    def torque_limit(self) -> float: ...

    def interpolation_period(self) -> float: ...

    def limit_target(self, target: float) -> float: ...

    def standstill(self) -> bool: ...

    def shift_position(self, delta: float) -> None: ...


class AxisDrive(Protocol):
    """The drive as one of its axes sees it: the object dictionary, EMCY, the clock."""

    store: ObjectStore
    emcy: EmcyProducer

    @property
    def lock(self) -> threading.RLock: ...

    def register_object(self, index: int, subindex: int = 0, *, reader: Callable[[], Any] | None = None,
                        validator: Callable[[Any], None] | None = None,
                        on_write: Callable[[Any], None] | None = None, early: bool = False) -> None: ...

    def cycle_period(self) -> float: ...

    def fault_cause_persists(self, axis: Any) -> bool: ...
