"""The simulated AKD as a CANopen node: its options, drive-level objects (0x1002, 0x1010/0x1011,
0x204C), FBUS.REMOTE, NMT without Enter Pre-Operational [2.2], expedited downloads of another
size [10.15], F129 for a lost heartbeat or life guarding [2.7, 2.8, 10.16] and F125 SYNC
supervision [1.6] (package docstring)."""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402 import objects as obj
from drive_bridge.cia402.modes import Mode
from drive_bridge.cia402.statemachine import State
from drive_bridge.model import NodeConfig
from drive_bridge.sim.akd.axis import AkdAxis
from drive_bridge.sim.akd.emcy import AkdEmcy
from drive_bridge.sim.akd.objects import (
    ABORT_INVALID_VALUE,
    ABORT_NOT_STORED,
    EMCY_SYNC_LOST,
    ENCODER_RESOLUTION,
    MANUFACTURER_STATUS,
    PV_SCALING,
    RESTORE_PARAMETERS,
    SIGNATURE_LOAD,
    SIGNATURE_SAVE,
    STORE_PARAMETERS,
    SYNC_SUPERVISION,
)
from drive_bridge.sim.akd.pdo import AkdPdoEngine
from drive_bridge.sim.akd.sdo import fit_expedited
from drive_bridge.sim.ascii_channel import AsciiChannel
from drive_bridge.sim.axis402 import Axis402
from drive_bridge.sim.drive402 import SimDrive402
from drive_bridge.sim.nmt import NmtCommand
from drive_bridge.sim.options import AXIS_OPTIONS, SLAVE_OPTIONS, OptionSpec
from drive_bridge.sim.registry import register_simulator
from drive_bridge.sim.store import key

AKD_OPTIONS: dict[str, OptionSpec] = {
    **SLAVE_OPTIONS,
    'life_guarding_reaction': replace(SLAVE_OPTIONS['life_guarding_reaction'], default='fault', choices=('fault',),
                                      doc='fixed on the AKD: F129 (EMCY 0x8130, brake to standstill, Fault)'),
    **AXIS_OPTIONS,
    # the generic defaults are for 2^16 counts per revolution; the AKD counts 2^20
    'inertia': replace(AXIS_OPTIONS['inertia'], default=2e-7),
    'friction': replace(AXIS_OPTIONS['friction'], default=1e-6),
    'velocity_pdo_rpm': OptionSpec('velocity_pdo_rpm', int, 0,
                                   '1: 0x606C is sent in rpm by PDO (manual §6.6), 0: counts/s as over SDO',
                                   0, 1),
}


@register_simulator('akd')
class SimAkd(SimDrive402):
    """A simulated Kollmorgen AKD; see the package docstring for what it reproduces."""

    OPTIONS = AKD_OPTIONS
    PDO_ENGINE = AkdPdoEngine
    EMCY_PRODUCER = AkdEmcy
    AXIS_CLASS = AkdAxis
    NMT_COMMANDS = frozenset(NmtCommand) - {NmtCommand.ENTER_PRE_OPERATIONAL}  # not one of the AKD's four

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        self.remote = True
        self._sync_lost = False
        super().__init__(node, options=options)
        pdo: AkdPdoEngine = self.pdo  # type: ignore[assignment]
        pdo.operational = lambda: self.nmt.operational
        if self.options['velocity_pdo_rpm'] and key(obj.VELOCITY_ACTUAL, 0) in self.store:
            pdo.pdo_readers[key(obj.VELOCITY_ACTUAL, 0)] = self._velocity_rpm
        store = self.store

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if key(index, subindex) in store:
                self.register_object(index, subindex, **hooks)

        reg(MANUFACTURER_STATUS, reader=lambda: self.axis_akd.manufacturer_status())
        reg(STORE_PARAMETERS, 1, reader=lambda: 1, validator=self._signature(SIGNATURE_SAVE),
            on_write=lambda value: self._save())
        reg(RESTORE_PARAMETERS, 1, reader=lambda: 1, validator=self._signature(SIGNATURE_LOAD),
            on_write=lambda value: self._load())
        for sub in (1, 2):
            reg(PV_SCALING, sub, validator=self._check_pv_scaling)
        AsciiChannel(self, save=self._save).install()  # 0x2026 and the ASCII parameters

    @property
    def axis_akd(self) -> AkdAxis:
        return self.axes[0]  # type: ignore[return-value]

    # -- inspection and test switches ----------------------------------------------------------------
    def set_remote(self, on: bool = True) -> None:
        """FBUS.REMOTE: False = another channel (WorkBench, Telnet) has control (bit 9 = 0)."""
        with self.lock:
            self.remote = bool(on)
            self.pdo.poll_events()

    @property
    def warnings(self) -> list[int]:
        """EMCY codes of the active warnings (n704 = 0x8584, n705 = 0x8585)."""
        with self.lock:
            return sorted(self.axis_akd.warnings)

    # -- objects -------------------------------------------------------------------------------------
    @staticmethod
    def _signature(expected: int) -> Callable[[int], None]:
        def check(value: int) -> None:
            if value != expected:
                raise SdoAbortedError(ABORT_NOT_STORED)
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
            axis.invalidate_parameters()

    @staticmethod
    def _check_pv_scaling(value: int) -> None:
        if value == 0:
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    def _velocity_rpm(self) -> int:
        increments = self.store.values.get(key(ENCODER_RESOLUTION, 1), 2 ** 20) or 2 ** 20
        revolutions = self.store.values.get(key(ENCODER_RESOLUTION, 2), 1)
        return int(round(self.axes[0].v * 60.0 * revolutions / increments))

    # -- hooks of the CiA 301 slave and the 402 drive ----------------------------------------------------
    def expedited_download(self, index: int, subindex: int, data: bytes, request: bytes) -> bytes:
        return fit_expedited(self.store, index, subindex, data, request)

    def on_reset_communication(self) -> None:
        self._sync_lost = False

    def on_heartbeat_lost(self, node: int) -> None:
        self.communication_lost('heartbeat')  # F129 (no node number in the EMCY)

    def on_life_guarding_lost(self) -> None:
        self.communication_lost('guarding')  # F129, whatever the generic option says

    def fault_cause_persists(self, axis: Axis402) -> bool:
        return self.heartbeat_monitor.lost or self.guarding.lost

    def supervise(self, now: float) -> bool:
        return self._supervise_sync(now)

    def _supervise_sync(self, now: float) -> bool:
        """F125 after three missing SYNC periods (FBUS.PARAM04 = 1); True when it was raised."""
        if not self.store.values.get(key(SYNC_SUPERVISION, 0), 0) or not math.isfinite(self.sync_clock.last_sync):
            self._sync_lost = False
            return False
        axis = self.axis_akd
        if axis.state is not State.OPERATION_ENABLED or axis.mode not in (Mode.INTERPOLATED_POSITION,
                                                                           Mode.CYCLIC_SYNC_POSITION):
            return False
        if now - self.sync_clock.last_sync <= 3 * axis.interpolation_period() + 0.005:
            self._sync_lost = False
            return False
        if self._sync_lost:
            return False
        self._sync_lost = True
        axis.fault(EMCY_SYNC_LOST)
        return True
