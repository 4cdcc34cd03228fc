"""Offline decoding: recorded raw frames through the bridge's own decoders, with no bus.

Each configured node gets an :class:`OfflineNode`: the master's :class:`ProcessImage`
(the same compiled PDO layouts that decode TPDOs live) fed with the recorded frames, and
the joint drivers its drive family creates live (``create_joint_driver``), so positions,
scaling, CiA 402 states and EMCY texts come out of the same code as on the robot. The
decoder is a plain loop over frames in time order: no thread, no clock, no sleep, so a
recording decodes faster than real time and always to the same result.

What the bridge publishes after each SYNC (joint states, axis states on change) is emitted
at each recorded SYNC frame; EMCYs and NMT/bus events when their frame is seen.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import can

from drive_bridge.bag.offline_node import OfflineNode
from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia301.nmt import NMT_COMMANDS, NmtState
from drive_bridge.cia402 import objects as obj
from drive_bridge.families import Liveness, get_family
from drive_bridge.joint import AxisSnapshot, JointDriver
from drive_bridge.master.events import EventKind, Level
from drive_bridge.master.pdo import ObjectKey
from drive_bridge.master.sync import SYNC_COB_ID
from drive_bridge.model import BusConfig

NMT_COB_ID = 0x000
EMCY_BASE = 0x080
HEARTBEAT_BASE = 0x700
NMT_TARGET = {0x01: NmtState.OPERATIONAL, 0x02: NmtState.STOPPED, 0x80: NmtState.PRE_OPERATIONAL,
              0x81: NmtState.INITIALISING, 0x82: NmtState.INITIALISING}
NMT_COMMAND = 'nmt_command'


@dataclass(frozen=True)
class JointSample:
    """What ``/joint_states`` carries after one cycle: the available joints."""

    stamp: float  # newest position stamp (as the bridge stamps it)
    names: tuple[str, ...]
    positions: tuple[float, ...]
    velocities: tuple[float, ...]
    efforts: tuple[float, ...]


@dataclass(frozen=True)
class AxisStatesSample:
    """What ``~/axis_states`` carries when an axis' state, mode or flags changed."""

    stamp: float  # the SYNC frame's time
    axes: tuple[AxisSnapshot, ...]


@dataclass(frozen=True)
class EmcySample:
    event: EmcyEvent
    joint: str  # '' when the EMCY names no single joint


@dataclass(frozen=True)
class BusNotice:
    """A bus event: the master's supervision events (``EventKind`` values) and NMT commands."""

    kind: str
    level: Level
    message: str
    node_id: int
    node_name: str
    timestamp: float


Decoded = JointSample | AxisStatesSample | EmcySample | BusNotice


class OfflineBus:
    """Feed frames in time order (:meth:`feed`); it returns what the bridge would have
    published because of each frame."""

    def __init__(self, config: BusConfig) -> None:
        self.config = config
        master = config.master
        self.nodes: dict[int, OfflineNode] = {}
        self.axes: dict[str, JointDriver] = {}
        self._by_cob: dict[int, Callable[[can.Message], Iterable[Decoded]]] = {}
        for node_cfg in config.nodes:
            family = get_family(node_cfg.family)
            timeout = (node_cfg.heartbeat_producer_ms * master.heartbeat_multiplier / 1000.0
                       if master.heartbeat_consumer else 0.0)
            node = OfflineNode(node_cfg, family, timeout)
            self.nodes[node.node_id] = node
            for axis_cfg in node_cfg.axes:
                self.axes[axis_cfg.joint] = node.family_node.create_joint_driver(node, axis_cfg, node_cfg.timeouts,
                                                                                 master.cycle_period)
            for cob_id in node.process.rx_layouts:
                self._by_cob[cob_id] = self._tpdo_handler(node)
            for cob_id in node.rpdo_layouts:
                self._by_cob[cob_id] = self._rpdo_handler(node)
        self._joint_of = {n.node_id: {a.slot: a.joint for a in n.axes} for n in config.nodes}
        self._last_states: tuple[object, ...] = ()
        self._last_inputs: tuple[object, ...] = ()
        # per node, the received objects an axis state can depend on: all but the motion values
        self._state_keys = {node_id: self._non_motion_keys(node) for node_id, node in self.nodes.items()}
        self._command_keys = {node_id: tuple((obj.for_axis(index, a.slot), 0) for a in node.config.axes
                                             for index in (obj.CONTROLWORD, obj.MODES_OF_OPERATION))
                              for node_id, node in self.nodes.items()}
        self.frames = 0
        self.syncs = 0
        self.node_frames = 0  # frames of the configured nodes (PDO, EMCY, heartbeat)

    # dispatch ---------------------------------------------------------------------------
    def feed(self, msg: can.Message) -> list[Decoded]:
        """Decode one recorded frame (frames must come in time order)."""
        self.frames += 1
        if msg.is_error_frame or msg.is_extended_id:
            return []
        cob_id = msg.arbitration_id
        out: list[Decoded] = list(self._check_liveness(msg.timestamp))
        handler = self._by_cob.get(cob_id)
        if handler is not None and not msg.is_remote_frame:
            self.node_frames += 1
            out.extend(handler(msg))
        elif cob_id == SYNC_COB_ID:
            self.syncs += 1
            out.extend(self._cycle(msg.timestamp))
        elif cob_id == NMT_COB_ID and len(msg.data) >= 2:
            out.extend(self._on_nmt_command(msg))
        elif EMCY_BASE < cob_id < EMCY_BASE + 0x80 and cob_id - EMCY_BASE in self.nodes:
            self.node_frames += 1
            out.extend(self._on_emcy(self.nodes[cob_id - EMCY_BASE], msg))
        elif HEARTBEAT_BASE < cob_id < HEARTBEAT_BASE + 0x80 and cob_id - HEARTBEAT_BASE in self.nodes \
                and not msg.is_remote_frame and len(msg.data) >= 1:
            self.node_frames += 1
            out.extend(self._on_heartbeat(self.nodes[cob_id - HEARTBEAT_BASE], msg))
        return out

    def problems(self) -> list[str]:
        """What did not fit the config: PDOs shorter than their mapping, a SYNC the recording lacks."""
        problems = [f'node {n.node_id} ({n.name}): {n.process.rx_errors} TPDO(s) shorter than the config maps, '
                    f'last: {n.process.last_rx_error}' for n in self.nodes.values() if n.process.rx_errors]
        master = self.config.master
        if master.sends_sync and not self.syncs and self.axes:
            problems.append(f'the config has master.sync_period {master.sync_period:g} s but the recording holds no '
                            f'SYNC frame (0x{SYNC_COB_ID:03X}): no joint or axis states decoded (decode with a config '
                            'whose sync_period is 0 to take them at each TPDO)')
        return problems

    def decode(self, frames: Iterable[can.Message]) -> Iterator[Decoded]:
        for msg in frames:
            yield from self.feed(msg)

    def _tpdo_handler(self, node: OfflineNode) -> Callable[[can.Message], Iterable[Decoded]]:
        def on_tpdo(msg: can.Message) -> Iterable[Decoded]:
            node.process.on_tpdo(msg.arbitration_id, bytes(msg.data), msg.timestamp)
            return () if self.config.master.sends_sync else self._cycle(msg.timestamp)
        return on_tpdo

    @staticmethod
    def _rpdo_handler(node: OfflineNode) -> Callable[[can.Message], Iterable[Decoded]]:
        def on_rpdo(msg: can.Message) -> Iterable[Decoded]:
            node.on_rpdo(msg.arbitration_id, bytes(msg.data))
            return ()
        return on_rpdo

    # what the bridge publishes each cycle -------------------------------------------------
    def _cycle(self, timestamp: float) -> list[Decoded]:
        out: list[Decoded] = []
        joints = self.joint_sample()
        if joints is not None:
            out.append(joints)
        inputs = self._state_inputs()
        if inputs == self._last_inputs:
            return out  # nothing but motion values changed: the axis states did not
        self._last_inputs = inputs
        snapshots = tuple(self.snapshot(joint) for joint in self.axes)
        key = tuple((s.available, s.drive_state, s.statusword, s.mode, s.controlword, s.fault, s.halted)
                    for s in snapshots)
        if snapshots and key != self._last_states:
            self._last_states = key
            out.append(AxisStatesSample(timestamp, snapshots))
        return out

    @staticmethod
    def _non_motion_keys(node: OfflineNode) -> tuple[ObjectKey, ...]:
        motion = set()
        for axis in node.config.axes:
            objects = node.family.axis_objects(axis.slot)
            motion |= {objects.position_actual, objects.velocity_actual, objects.effort_actual}
        return tuple(f.key for layout in node.process.rx_layouts.values() for f in layout.fields
                     if f.key not in motion)

    def _state_inputs(self) -> tuple[object, ...]:
        """Everything an axis snapshot's published state can change with, cheaply."""
        return tuple((node.available, node.state, len(node.emcy_history()),
                      tuple(node.process.inputs.get(k) for k in self._state_keys[node_id]),
                      tuple(node.outputs.get(k) for k in self._command_keys[node_id]))
                     for node_id, node in self.nodes.items())

    def joint_sample(self) -> JointSample | None:
        """The available joints now, as ``/joint_states`` carries them (None: none available)."""
        rows = [(joint, *axis.feedback()) for joint, axis in self.axes.items()]
        rows = [r for r in rows if r[1]]
        if not rows:
            return None
        return JointSample(max(r[5] for r in rows), tuple(r[0] for r in rows), tuple(r[2] for r in rows),
                           tuple(r[3] for r in rows), tuple(r[4] for r in rows))

    def snapshot(self, joint: str) -> AxisSnapshot:
        """The joint driver's snapshot, with the controlword and mode the master actually sent."""
        axis = self.axes[joint]
        snapshot = axis.snapshot()
        node = self.nodes[axis.node_id]
        slot = axis.config.slot
        controlword = node.outputs.get((obj.for_axis(obj.CONTROLWORD, slot), 0))
        mode = node.outputs.get((obj.for_axis(obj.MODES_OF_OPERATION, slot), 0))
        return dataclasses.replace(
            snapshot, controlword=snapshot.controlword if controlword is None else int(controlword),
            requested_mode=snapshot.requested_mode if mode is None else int(mode))

    # CiA 301 services ----------------------------------------------------------------------
    def _on_emcy(self, node: OfflineNode, msg: can.Message) -> list[Decoded]:
        event = node.on_emcy(bytes(msg.data), msg.timestamp)
        joints = self._joint_of.get(node.node_id, {})
        if event.slot is not None:
            joint = joints.get(event.slot, '')
        else:
            joint = next(iter(joints.values())) if len(joints) == 1 else ''
        return [EmcySample(event, joint)]

    def _on_heartbeat(self, node: OfflineNode, msg: can.Message) -> list[Decoded]:
        code = msg.data[0]
        before, was_lost = node.state, node.lost
        node.on_nmt_state(code, msg.timestamp)
        out: list[Decoded] = []
        if code == 0:
            rebooted = before is NmtState.OPERATIONAL or was_lost
            out.append(BusNotice((EventKind.UNEXPECTED_BOOT if rebooted else EventKind.BOOTED).value,
                                Level.WARN if rebooted else Level.INFO,
                                f'node {node.node_id} ({node.name}): boot-up'
                                + (' while operational (reset or power cycle)' if rebooted else ''),
                                node.node_id, node.name, msg.timestamp))
            node.lost = False
        elif was_lost:
            node.lost = False
            kind = EventKind.GUARDING_BACK if node.liveness is Liveness.GUARDING else EventKind.HEARTBEAT_BACK
            what = kind.value.replace('_', ' ')
            out.append(BusNotice(kind.value, Level.WARN, f'node {node.node_id} ({node.name}): {what}, {node.state}',
                                 node.node_id, node.name, msg.timestamp))
        return out

    def _check_liveness(self, now: float) -> list[BusNotice]:
        out: list[BusNotice] = []
        for node in self.nodes.values():
            if node.lost or not node.heartbeat_timeout or node.last_heartbeat is None \
                    or node.liveness is not Liveness.HEARTBEAT or node.state is not NmtState.OPERATIONAL:
                continue
            age = now - node.last_heartbeat
            if age > node.heartbeat_timeout:
                node.lost = True
                out.append(BusNotice(EventKind.HEARTBEAT_LOST.value, Level.ERROR,
                                    f'node {node.node_id} ({node.name}): heartbeat lost, none for '
                                    f'{age * 1000:.0f} ms (limit {node.heartbeat_timeout * 1000:.0f} ms)',
                                    node.node_id, node.name, now))
        return out

    def _on_nmt_command(self, msg: can.Message) -> list[Decoded]:
        command, target = msg.data[0], msg.data[1]
        name = NMT_COMMANDS.get(command)
        if name is None:
            return []
        nodes = list(self.nodes.values()) if target == 0 else [self.nodes[target]] if target in self.nodes else []
        for node in nodes:
            if node.liveness is Liveness.NONE:  # a supervised node reports its new state itself
                node.state = NMT_TARGET[command]
        who = 'all nodes' if target == 0 else (f'node {target} ({nodes[0].name})' if nodes else f'node {target}')
        return [BusNotice(NMT_COMMAND, Level.INFO, f'NMT {name}: {who}', target,
                          nodes[0].name if len(nodes) == 1 else '', msg.timestamp)]
