"""The simulated SERVOSTAR 400/600 as a CANopen node: options, boot-up EMCY, NMT, node guarding
with the n04 reaction, errors by category, save / cold start, the object channel and the ASCII
terminal, expedited-only SDO (package docstring)."""
from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.cia402.statemachine import State
from drive_bridge.model import NodeConfig
from drive_bridge.sim.akd.sdo import fit_expedited
from drive_bridge.sim.drive402 import SimDrive402
from drive_bridge.sim.emcy import COB_ID_EMCY, COB_ID_INVALID
from drive_bridge.sim.nmt import NmtCommand
from drive_bridge.sim.registry import register_simulator
from drive_bridge.sim.servostar.ascii import AsciiTerminal
from drive_bridge.sim.servostar.axis import ServostarAxis
from drive_bridge.sim.servostar.emcy import ServostarEmcy, category_of
from drive_bridge.sim.servostar.modes import MotionTask
from drive_bridge.sim.servostar.objects import (
    ABORT_COMMAND,
    ABORT_INVALID_VALUE,
    ABORT_STATE,
    CLRFAULT,
    COLDSTART,
    DRVCNFG,
    DRVCNFG_BOOT_SHORT_BIT0,
    DRVCNFG_LENGTH_CHECK,
    DRVSTAT,
    EMCY_FOLLOWING_ERROR,
    EMCY_NOT_ENABLED,
    EMCY_NOT_OPERATION_ENABLE,
    EMCY_ONLY_DISABLED,
    EMCY_RESPONSE_MONITORING,
    EMCY_TASK_NUMBER,
    EMCY_TRAJECTORY,
    EMCY_WRONG_MODE,
    FAULT_NUMBERS,
    MDRV,
    PDO33_HALF,
    PEMAX,
    POSITION_CONTROLLER,
    RPDO_SELECT,
    SAVE,
    STATUS_BYTES,
    STATUS_REGISTER,
    TPDO_SELECT,
    VALUE,
    WARN_FOLLOWING_ERROR,
    WARN_RESPONSE_MONITORING,
)
from drive_bridge.sim.servostar.options import SERVOSTAR_OPTIONS
from drive_bridge.sim.servostar.pdo import ServostarPdoEngine
from drive_bridge.sim.servostar.storage import DriveStorage
from drive_bridge.sim.store import key


@register_simulator('servostar')
class SimServostar(SimDrive402):
    """A simulated Kollmorgen SERVOSTAR 400/600; see the package docstring for what it reproduces."""

    OPTIONS = SERVOSTAR_OPTIONS
    PDO_ENGINE = ServostarPdoEngine
    EMCY_PRODUCER = ServostarEmcy
    AXIS_CLASS = ServostarAxis

    def __init__(self, node: NodeConfig, *, options: Mapping[str, Any] | None = None) -> None:
        self.hardware_enable = True
        self.dc_link = True
        self._persistent: dict[int, int] = {}  # code -> category: comes back after every reset
        self.boot_messages = 0
        super().__init__(node, options=options)
        if self.options['bootup_length_bit'] not in (0, 2):
            raise ValueError(f"simulation option 'bootup_length_bit' of node {node.name!r}: 0 or 2")
        if self.options['nmt_undocumented'] == 'ignore':
            self.NMT_COMMANDS = frozenset({NmtCommand.START, NmtCommand.STOP, NmtCommand.RESET_NODE})
        self.hardware_enable = self.options['hardware_enable']
        self.star_emcy.register_reading = self.options['emcy_error_register']
        self.star_emcy.follow_up_category = self.options['emcy_follow_up_category']
        if key(DRVCNFG, VALUE) in self.store:
            self.store.set_default(DRVCNFG, VALUE, self.options['drvcnfg'])
        self.storage = DriveStorage(self.store)
        pdo = self.star_pdo
        pdo.trajectory_offset = self._trajectory_offset
        self.terminal = AsciiTerminal(self.store, self._terminal_write, lambda index: self.value(index, VALUE),
                                      pdo.send_ascii)
        pdo.ascii_received = self.terminal.receive
        self._register_drive_objects()

    @property
    def star_pdo(self) -> ServostarPdoEngine:
        return self.pdo  # type: ignore[return-value]

    @property
    def star_emcy(self) -> ServostarEmcy:
        return self.emcy  # type: ignore[return-value]

    @property
    def axis_star(self) -> ServostarAxis:
        return self.axes[0]  # type: ignore[return-value]

    # -- objects ---------------------------------------------------------------------------------------
    def _register_drive_objects(self) -> None:
        store = self.store

        def reg(index: int, subindex: int = 0, **hooks: Any) -> None:
            if key(index, subindex) in store:
                self.register_object(index, subindex, **hooks)

        reg(STATUS_REGISTER, reader=lambda: self.axis_star.status_register())
        reg(DRVSTAT, VALUE, reader=self._drvstat)
        for sub in range(1, 11):
            reg(STATUS_BYTES, sub, reader=lambda sub=sub: self._status_byte(sub))
        self.storage.register(reg)
        reg(SAVE, VALUE, on_write=lambda v: self.save())
        reg(COLDSTART, VALUE, validator=lambda v: self.check_disabled(), on_write=lambda v: self.restart(True))
        reg(CLRFAULT, VALUE, on_write=lambda v: self._clear_faults())
        reg(PEMAX, VALUE, reader=lambda: self.store.values[key(POSITION_CONTROLLER, 3)],
            on_write=self._set_pemax)
        reg(0x3500, VALUE, reader=lambda: len(self.terminal.names))  # MAXSDO: objects in the channel
        reg(MDRV, VALUE, on_write=lambda v: self.pdo.rebuild())
        reg(PDO33_HALF, validator=self._check_half)
        for transmit, base in ((False, RPDO_SELECT), (True, TPDO_SELECT)):
            for channel in range(1, 5):
                reg(base + channel - 1, validator=lambda v, t=transmit: self.star_pdo.check_select(t, v),
                    on_write=lambda v, t=transmit, n=channel: self.star_pdo.select(t, n, v))

    def _drvstat(self) -> int:
        status = self.axis_star.status_register()
        return status - (1 << 32) if status >> 31 else status  # DRVSTAT is an INTEGER32

    def _status_byte(self, sub: int) -> int:
        status = self.axis_star.status_register()
        if sub == 1:
            return 1 if self.hardware_enable else 0
        if sub == 2:
            return (1 if self.axis_star.warnings else 0) | (2 if self.error_pending() else 0)
        return status >> (8 * ((sub - 3) % 4)) & 0xFF  # DRVSTAT bytes 0..3, TRJSTAT bytes 0..3

    def _set_pemax(self, value: int) -> None:
        self.store.values[key(POSITION_CONTROLLER, 3)] = value

    def _check_half(self, value: int) -> None:
        allowed = {'offset': (0, 4), 'index': (0, 1), 'nonzero': (0, 1, 2, 3, 4)}[self.options['pdo33_half_select']]
        if value not in allowed:
            raise SdoAbortedError(ABORT_INVALID_VALUE)

    def _trajectory_offset(self) -> int:
        value = self.store.values.get(key(PDO33_HALF), 0)
        high = value == 1 if self.options['pdo33_half_select'] == 'index' else value != 0
        return 4 if high else 0

    def _terminal_write(self, index: int, value: Any) -> None:
        self.write_object(key(index, VALUE), value)

    # -- save (storage.py), cold start --------------------------------------------------------------------
    def save(self) -> None:
        """SAVE (35EBh): the drive parameters in EEPROM become the power-on values."""
        self.storage.save()

    def check_disabled(self) -> None:
        """Commands and parameters of status "Disabled": refused while the output stage is enabled
        (SDO 0x08000022 and EMCY 0x7182)."""
        if self.axis_star.stage_enabled:
            self.emcy.error(EMCY_ONLY_DISABLED, 'operation', transient=True)
            raise SdoAbortedError(ABORT_STATE)

    # -- hooks of the CiA 301 slave ---------------------------------------------------------------------
    def announce_bootup(self) -> None:
        """The power-on telegram: an EMCY with 8 zero bytes, or 0 bytes with the DRVCNFG bit."""
        cob = self.store.values.get(key(COB_ID_EMCY, 0), 0x80 + self.node_id)
        if cob & COB_ID_INVALID:
            return
        short = self.store.values.get(key(DRVCNFG, VALUE), 0) & (
            DRVCNFG_BOOT_SHORT_BIT0 if self.options['bootup_length_bit'] == 0 else DRVCNFG_LENGTH_CHECK)
        self.boot_messages += 1
        self.send(cob & 0x7FF, b'' if short else bytes(8))

    def on_reset_communication(self) -> None:
        """The PDO configuration after power-on / reset: the library defaults, or what 0x1010:2
        stored when DRVCNFG bit 3 is set."""
        self.storage.load_communication()

    def on_boot(self) -> None:
        super().on_boot()
        for code, category in list(self._persistent.items()):
            self._raise(code, category)

    def refuse_sdo_request(self, request: bytes) -> int | None:
        """Expedited transfer only [2.4]: initiate download (expedited), initiate upload and abort are
        served; segmented and block requests are aborted with 0x05040001."""
        command = request[0] & 0xE0 if request else 0xE0
        if command == 0x20 and request[0] & 0x02 or command in (0x40, 0x80):
            return None
        return ABORT_COMMAND

    def expedited_download(self, index: int, subindex: int, data: bytes, request: bytes) -> bytes:
        """Without the DRVCNFG bit 2 length check, any size is fitted to the object [2.4]."""
        if self.store.values.get(key(DRVCNFG, VALUE), 0) & DRVCNFG_LENGTH_CHECK:
            return data
        return fit_expedited(self.store, index, subindex, data, request)

    def on_life_guarding_lost(self) -> None:
        """n04: only while the output stage is enabled (monitoring starts again at the next enable)."""
        axis = self.axis_star
        if not axis.stage_enabled:
            return
        axis.warnings |= WARN_RESPONSE_MONITORING
        if EMCY_RESPONSE_MONITORING not in self.star_emcy.codes('cat2'):
            self.emcy.error(EMCY_RESPONSE_MONITORING, 'cat2')
        axis.error_stop()

    def on_life_guarding_recovered(self) -> None:
        """RTRs again: n04 stays until the acknowledge (controlword bit 11)."""

    def stage_changed(self, enabled: bool) -> None:
        """The output stage went on or off: life guarding runs only while it is on."""
        if enabled:
            self.guarding.rearm(time.monotonic())  # the life time starts now

    # -- errors ----------------------------------------------------------------------------------------------
    def error_pending(self) -> bool:
        return self.emcy.is_active('cat1') or self.emcy.is_active('cat2')

    def fault_pending(self) -> bool:
        return self.emcy.is_active('cat1')

    def motion_blocked(self) -> bool:
        return self.emcy.is_active('cat2')

    def can_switch_on(self) -> bool:
        return self.hardware_enable and self.dc_link and not self.fault_pending()

    def enable_refused(self) -> None:
        self.emcy.error(EMCY_NOT_ENABLED, 'operation', transient=True)

    def errcode(self) -> int:
        """ERRCODE 0x2070:16: bit n = fault F(n+1) of the pending errors."""
        bits = 0
        for code in self.emcy.active_codes:
            number = FAULT_NUMBERS.get(code)
            if number:
                bits |= 1 << (number - 1)
        return bits

    def _raise(self, code: int, category: int) -> None:
        """An error's EMCY pair and its reaction by category."""
        axis = self.axis_star
        if category in (1, 4):
            self.emcy.error(code, 'cat1', bytes([category]))
            axis.stage_off(not_ready=True)
        elif category == 2:
            if code not in self.star_emcy.codes('cat2'):
                self.emcy.error(code, 'cat2', bytes([category]))
            axis.error_stop()
        else:
            self.emcy.error(code, 'operation', bytes([category]), transient=True)

    def following_error(self, axis: ServostarAxis) -> None:
        """PEMAX exceeded (or a too big trajectory step): warning n03, EMCY 0x8611, emergency ramp."""
        axis.warnings |= WARN_FOLLOWING_ERROR
        self._raise(EMCY_FOLLOWING_ERROR, 2)

    def trajectory_error(self, axis: ServostarAxis) -> None:
        self._raise(EMCY_TRAJECTORY, 2)

    def start_motion_task(self, axis: ServostarAxis, number: int) -> None:
        if not isinstance(axis.mode_impl, MotionTask):
            self._raise(EMCY_WRONG_MODE, 5)
        elif axis.state is not State.OPERATION_ENABLED:
            self._raise(EMCY_NOT_OPERATION_ENABLE, 5)
        elif number != 0:
            self._raise(EMCY_TASK_NUMBER, 5)  # no stored motion tasks in the simulation
        else:
            axis.start_task()

    def acknowledge(self) -> None:
        """Controlword bit 11: category 2 errors and warnings n03 / n04 go (not a persistent cause)."""
        axis = self.axis_star
        keep = frozenset(code for code, category in self._persistent.items() if category == 2)
        axis.warnings &= ~(WARN_FOLLOWING_ERROR | WARN_RESPONSE_MONITORING)
        self.star_emcy.clear('cat2', keep)
        if not self.motion_blocked():
            axis.release()
        self.guarding.rearm(time.monotonic())

    def reset_fault(self) -> None:
        """Controlword bit 7 with a category 1 error pending: the drive restarts (cold start)."""
        self.restart(True)

    def _clear_faults(self) -> None:
        """CLRFAULT (3518h): category 2 acknowledged, a category 1 error restarts the drive."""
        self.acknowledge()
        if self.fault_pending():
            self.restart(True)

    # -- fault injection and test switches ------------------------------------------------------------
    def inject_fault(self, code: int, category: int | None = None, persistent: bool = False,  # type: ignore[override]
                     axis: int = 0, manufacturer: bytes = b'') -> None:
        """Raise the error ``code`` with its EMCY pair and the reaction of its ``category`` (default:
        the manual's table): 1/4 output stage off (Switch On Disabled) until bit 7 / COLDSTART
        restarts the drive; 2 emergency ramp and motion blocked until bit 11; 3/5 the EMCY pair
        only. ``persistent``: it comes back after every restart / acknowledge until
        :meth:`clear_fault_cause`."""
        with self.lock:
            category = category_of(code) if category is None else category
            if persistent:
                self._persistent[code] = category
            self._raise(code, category)
            self.pdo.poll_events()

    def clear_fault_cause(self, axis: int | None = None, code: int | None = None) -> None:
        """The persistent cause of ``code`` (all if None) is gone: a reset clears it again."""
        with self.lock:
            if code is None:
                self._persistent.clear()
            else:
                self._persistent.pop(code, None)

    def set_hardware_enable(self, on: bool = True) -> None:
        """The hardware enable input (transition 3 needs it; off switches the output stage off)."""
        with self.lock:
            self.hardware_enable = bool(on)
            if not on:
                self.axis_star.stage_off()
            self.pdo.poll_events()

    def set_dc_link(self, on: bool = True) -> None:
        """DC-link voltage present (statusword bit 4 = 0); off switches the output stage off."""
        with self.lock:
            self.dc_link = bool(on)
            if not on:
                self.axis_star.stage_off()
            self.pdo.poll_events()

    # -- views for tests --------------------------------------------------------------------------------
    @property
    def status_register(self) -> int:
        with self.lock:
            return self.axis_star.status_register()

    @property
    def errors(self) -> dict[str, list[int]]:
        """Pending error codes by category class: 'cat1' (restart needed), 'cat2' (bit 11)."""
        with self.lock:
            return {source: self.star_emcy.codes(source) for source in ('cat1', 'cat2')}

    @property
    def ascii_log(self) -> list[tuple[str, str]]:
        with self.lock:
            return list(self.terminal.log)

    def selected_pdos(self) -> dict[str, list[int]]:
        """Library numbers per channel: {'rpdo': [ch1..ch4], 'tpdo': [...]}."""
        with self.lock:
            values = self.store.values
            return {'rpdo': [values[key(RPDO_SELECT + n)] for n in range(4)],
                    'tpdo': [values[key(TPDO_SELECT + n)] for n in range(4)]}

    def mapping(self, transmit: bool, channel: int) -> list[int]:
        """The mapping entries of a channel as its 0x16xx / 0x1Axx shows them."""
        with self.lock:
            index = (0x1A00 if transmit else 0x1600) + channel - 1
            values = self.store.values
            return [values[key(index, s)] for s in range(1, values[key(index, 0)] + 1)]

    @property
    def saved_communication(self) -> bool:
        return self.storage.saved_comm is not None

