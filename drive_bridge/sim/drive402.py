"""SimDrive402: a simulated CiA 402 drive with one axis per 0x800 slot of its EDS.

Adds to the CiA 301 slave the axes, the drive's reaction to a lost master heartbeat
(EMCY 0x8130, then the fault reaction on every axis: the safety net when the bridge
dies), the same reaction to lost life guarding when the option
``life_guarding_reaction`` is 'fault', and the drive-level fault injection used by
the master's tests.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from drive_bridge.cia402 import objects as obj
from drive_bridge.model import NodeConfig
from drive_bridge.sim.axis402 import Axis402
from drive_bridge.sim.hooks import EMCY_HEARTBEAT
from drive_bridge.sim.options import AXIS_OPTIONS, DRIVE_OPTIONS, OptionSpec
from drive_bridge.sim.slave import SimulatedSlave


class SimDrive402(SimulatedSlave):
    """A CiA 402 drive; ``axis(k)`` is the axis whose objects sit at index + 0x800*k.

    Hooks beyond the CiA 301 slave's: ``AXIS_CLASS`` (the family's axis), :meth:`communication_lost`
    (the drive's reaction to a lost master) and :meth:`fault_cause_persists`.
    """

    OPTIONS: dict[str, OptionSpec] = {**DRIVE_OPTIONS, **AXIS_OPTIONS}
    AXIS_CLASS: type[Axis402] = Axis402  # device models may bring their own axis behaviour

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        super().__init__(node, options=options)
        count = self.axis_count(node)
        self.axes: tuple[Axis402, ...] = tuple(
            self.AXIS_CLASS(self, slot, {name: self.options[name][slot]
                                         for name, spec in self.OPTIONS.items() if spec.per_axis})
            for slot in range(count))
        self.on_axes_created()

    def on_axes_created(self) -> None:
        """Hook: the axes exist (e.g. settle what the EDS leaves open). Default: nothing."""

    @staticmethod
    def axis_count(node: NodeConfig) -> int:
        """The axes the EDS has a controlword 0x6040 (+ 0x800 per slot) for."""
        count = 0
        while count < obj.MAX_AXES and obj.for_axis(obj.CONTROLWORD, count) in node.od:
            count += 1
        if count == 0:
            raise ValueError(f'node {node.name!r}: a CiA 402 simulator needs a controlword 0x6040 in its EDS')
        return count

    def axis(self, slot: int = 0) -> Axis402:
        try:
            return self.axes[slot]
        except IndexError:
            raise IndexError(f'node {self.name!r} has {len(self.axes)} axes, no slot {slot}') from None

    # ---- model hooks -------------------------------------------------------------------
    def reset_application(self) -> None:
        for axis in self.axes:
            axis.reset()

    def on_boot(self) -> None:
        for axis in self.axes:
            axis.boot()

    def model_step(self, dt: float, sync: bool) -> None:
        for axis in self.axes:
            axis.advance(dt, sync)
        if sync:  # new set-points start at this SYNC, after the step that ended at it
            for axis in self.axes:
                axis.on_sync()

    def on_heartbeat_lost(self, node: int) -> None:
        self.communication_lost('heartbeat', bytes([node]))

    def on_life_guarding_lost(self) -> None:
        if self.options['life_guarding_reaction'] == 'fault':
            self.communication_lost('guarding')
        else:
            super().on_life_guarding_lost()

    def communication_lost(self, source: str, manufacturer: bytes = b'') -> None:
        """Hook: the master is gone (``source`` 'heartbeat' or 'guarding'). Default: EMCY 0x8130,
        then every axis' fault reaction and Fault (one EMCY for all axes)."""
        self.emcy.error(EMCY_HEARTBEAT, source, manufacturer=manufacturer)
        for axis in self.axes:
            axis.fault(EMCY_HEARTBEAT, emit=False)

    def fault_cause_persists(self, axis: Axis402) -> bool:
        """Hook: a fault reset fails while this holds (the master's heartbeat, or its guarding
        when that faults the drive, is still missing)."""
        guarding = self.options['life_guarding_reaction'] == 'fault' and self.guarding.lost
        return self.heartbeat_monitor.lost or guarding

    # ---- fault injection ---------------------------------------------------------------
    def inject_fault(self, code: int, axis: int = 0, manufacturer: bytes = b'', persistent: bool = False) -> None:
        """Raise a drive fault on ``axis``: EMCY (code, 0x1001, ``manufacturer``), 0x603F,
        fault reaction per 0x605E, then Fault. ``persistent``: fault resets fail until
        :meth:`clear_fault_cause`."""
        with self._lock:
            self.axis(axis).fault(code, bytes(manufacturer), persistent)
            self.pdo.poll_events()

    def clear_fault_cause(self, axis: int | None = None) -> None:
        """The persistent cause is gone (of ``axis``, or all); a fault reset works again."""
        with self._lock:
            for ax in self.axes if axis is None else (self.axis(axis),):
                ax.persistent_fault = False
                ax.persistent_code = 0
