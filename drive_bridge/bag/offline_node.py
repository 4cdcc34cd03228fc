"""One node as its joint drivers see it while a recording is decoded: no bus behind it."""
from __future__ import annotations

from collections import deque
from collections.abc import Callable

from drive_bridge.bag.errors import OfflineSdoError
from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia301.nmt import NmtState
from drive_bridge.families import BootDetection, DriveFamily
from drive_bridge.master.node import EMCY_HISTORY
from drive_bridge.master.pdo import ObjectKey, PdoLayout, ProcessImage, od_variable
from drive_bridge.model import NodeConfig


class OfflineNode:
    """A node as the joint drivers see it (:class:`~drive_bridge.joint.NodeIo`), its inputs
    decoded from recorded TPDOs, its NMT state from recorded heartbeats and NMT commands."""

    def __init__(self, config: NodeConfig, family: DriveFamily, heartbeat_timeout: float) -> None:
        self.config = config
        self.family = family
        self.family_node = family.node(config)  # its joint drivers, its EMCYs' meaning
        self.process = ProcessImage(config.od, config.rpdo, config.tpdo, family.sent_on_write)
        # RPDOs the master sent, decoded with the same layouts: the controlword actually sent
        self.rpdo_layouts: dict[int, PdoLayout] = {layout.cob_id: layout for layout in self.process.tx_layouts}
        self.outputs: dict[ObjectKey, int | float] = {}
        self.state = NmtState.UNKNOWN
        self.liveness = family.liveness(config)
        self.heartbeat_timeout = heartbeat_timeout
        self.last_heartbeat: float | None = None
        self.lost = False
        self._emcy: deque[EmcyEvent] = deque(maxlen=EMCY_HISTORY)

    # NodeIo ----------------------------------------------------------------------------
    @property
    def node_id(self) -> int:
        return self.config.node_id

    @property
    def name(self) -> str:
        return self.config.name

    @property
    def available(self) -> bool:
        return self.state is NmtState.OPERATIONAL and not self.lost

    @property
    def nmt_state(self) -> str:
        return str(self.state)

    @property
    def boot_error(self) -> str:
        return f'heartbeat lost (none for {self.heartbeat_timeout:g} s)' if self.lost else ''

    def read(self, index: int, subindex: int = 0) -> int | float | None:
        return self.process.get(index, subindex)

    def write(self, index: int, subindex: int, value: int | float) -> None:
        """Offline nothing is sent; the outputs come from the recorded RPDOs."""

    def stamp(self, index: int, subindex: int = 0) -> float:
        return self.process.input_stamps.get((index, subindex), 0.0)

    def has_object(self, index: int, subindex: int = 0) -> bool:
        return od_variable(self.config.od, index, subindex) is not None

    def sdo_read(self, index: int, subindex: int = 0) -> int | float | str | bytes:
        raise OfflineSdoError(f'node {self.node_id} ({self.name}): SDO read of 0x{index:04X}:{subindex:02X} '
                              'asked while decoding a recording (no bus to answer it)')

    def sdo_write(self, index: int, subindex: int, value: int | float) -> None:
        raise OfflineSdoError(f'node {self.node_id} ({self.name}): SDO write of 0x{index:04X}:{subindex:02X} '
                              'asked while decoding a recording (no bus to answer it)')

    def emcy_history(self) -> tuple[EmcyEvent, ...]:
        return tuple(self._emcy)

    def add_input_listener(self, listener: Callable[[frozenset[ObjectKey], float], None]) -> None:
        self.process.add_input_listener(listener)

    def report_setpoint_refused(self, joint: str, text: str) -> None:
        """A replayed cycle sends nothing: there is no one to tell."""

    # recorded frames --------------------------------------------------------------------
    def on_rpdo(self, cob_id: int, data: bytes) -> None:
        layout = self.rpdo_layouts[cob_id]
        if len(data) >= layout.length:
            self.outputs.update(layout.unpack(data))

    def on_emcy(self, data: bytes, timestamp: float) -> EmcyEvent:
        if self.family.boot.detection is BootDetection.EMCY and self.family.is_bootup_emcy(data) \
                and not (self.state is NmtState.OPERATIONAL and self.family.bootup_emcy_is_ambiguous(data)):
            self.state = NmtState.PRE_OPERATIONAL
        event = self.family_node.decode_emcy(data, timestamp)
        self._emcy.append(event)
        return event

    def on_nmt_state(self, code: int, timestamp: float) -> None:
        """A heartbeat, guarding reply or boot-up frame."""
        self.last_heartbeat = timestamp
        self.state = NmtState.from_code(code)
