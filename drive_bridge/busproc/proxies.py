"""Node-side stand-ins for the bus process's joint drivers, trajectory handles, nodes and
parameter access, with the API the ROS layer used on the real objects.

Reading is local and never waits: a joint's feedback is the newest cyclic state, its snapshot
the newest one the bus process sent (its position, velocity and effort from the cyclic
state). Intents are requests to the bus process (:class:`~.client.BusClient` sends them) and
wait for its answer; stops go on the stop lane.
"""
from __future__ import annotations

import concurrent.futures
import dataclasses
import math
from collections.abc import Callable
from typing import Protocol

from drive_bridge.busproc.cyclic import Feedback
from drive_bridge.busproc.intents import AxisIntent, AxisIntentName, ParameterCall, Query, Stop
from drive_bridge.busproc.reports import HandleState
from drive_bridge.cia301.emcy import EmcyEvent
from drive_bridge.cia402.statemachine import State
from drive_bridge.families import DriveFamily
from drive_bridge.families.parameters import ParameterAccess, ParameterValue
from drive_bridge.joint import AxisSnapshot, DriveState, JointError
from drive_bridge.joint.strategy import StreamStrategy
from drive_bridge.master.sdo import od_data_type
from drive_bridge.model import AxisConfig, NodeConfig
from drive_bridge.streaming.executor import TrajectoryHandle

NO_FEEDBACK: Feedback = (False, math.nan, math.nan, math.nan, 0.0)
INTENT_MARGIN = 5.0  # s an intent's answer may take beyond its own timeout
DEFAULT_INTENT_WAIT = 60.0  # s for an intent without a timeout (the axis applies its own)


def _initial(joint: str, node: NodeConfig, config: AxisConfig) -> AxisSnapshot:
    return AxisSnapshot(
        joint=joint, node_id=node.node_id, node_name=node.name, slot=config.slot, available=False,
        nmt_state='UNKNOWN', drive_state=DriveState.UNAVAILABLE, state=State.UNKNOWN, statusword=0, controlword=0,
        mode=0, mode_name='', requested_mode=config.mode, position=math.nan, velocity=math.nan, effort=math.nan,
        stamp=0.0, fault=False, warning=False, target_reached=False, internal_limit=False, following_error=False,
        halted=False, command_stale=False, last_emcy=None, message='bus process starting')


class AxisClient(Protocol):
    """What an axis's stand-in needs of :class:`~.client.BusClient` (which builds it, so it is not
    named here): an intent waits for its answer on the request lane, a stop goes on the stop lane."""

    def call(self, body: object, timeout: float | None = None) -> object: ...

    def stop(self, body: Stop) -> concurrent.futures.Future[object]: ...


class AxisProxy:
    """One joint of the bus process (the JointDriver protocol's reading side and intents)."""

    def __init__(self, client: AxisClient, node: NodeConfig, config: AxisConfig, cycle_period: float) -> None:
        self.client = client
        self.joint = config.joint
        self.config = config
        self.cycle_period = cycle_period
        self._node_id = node.node_id
        self._feedback: Feedback = NO_FEEDBACK
        self._snapshot = _initial(self.joint, node, config)
        self._key: tuple[object, ...] = ()
        self._command_field: str | None = None
        self._strategy: StreamStrategy | None = None
        self.lost_reason = ''

    # -- updates from the bus process (the client's reader threads) ------------------------------------
    def on_feedback(self, feedback: Feedback) -> None:
        self._feedback = feedback

    def on_snapshot(self, snapshot: AxisSnapshot, command_field: str | None, strategy: StreamStrategy | None) -> None:
        self._snapshot = snapshot
        self._command_field = command_field
        self._strategy = strategy
        self._key = (snapshot.available, snapshot.statusword, snapshot.mode, snapshot.controlword,
                     snapshot.command_stale, snapshot.halted, snapshot.message, snapshot.drive_state,
                     snapshot.requested_mode)

    def on_lost(self, reason: str) -> None:
        """The bus process is gone: unavailable from now on, saying why."""
        self.lost_reason = reason
        self._feedback = NO_FEEDBACK
        self._snapshot = dataclasses.replace(self._snapshot, available=False, drive_state=DriveState.UNAVAILABLE,
                                             message=reason)
        self._key = ('lost', reason)

    # -- reading (never waits) --------------------------------------------------------------------------
    @property
    def node_id(self) -> int:
        return self._node_id

    @property
    def ready(self) -> bool:
        return self._snapshot.available

    @property
    def available(self) -> bool:
        return self._snapshot.available and not self.lost_reason

    @property
    def drive_state(self) -> DriveState:
        return self._snapshot.drive_state

    @property
    def state(self) -> State:
        return State(int(self._snapshot.state))

    @property
    def halted(self) -> bool:
        return self._snapshot.halted

    @property
    def mode(self) -> int:
        return self._snapshot.requested_mode

    def feedback(self) -> Feedback:
        return self._feedback

    def snapshot(self) -> AxisSnapshot:
        available, position, velocity, effort, stamp = self._feedback
        snapshot = self._snapshot
        if not stamp:
            return snapshot
        return dataclasses.replace(snapshot, position=position, velocity=velocity, effort=effort, stamp=stamp)

    def state_key(self) -> tuple[object, ...]:
        return self._key

    def last_emcy(self) -> EmcyEvent | None:
        return self._snapshot.last_emcy

    def command_field(self) -> str | None:
        return self._command_field

    def stop_deceleration(self) -> float:
        """SI deceleration of a controlled stop (asks the bus process: it may read the drive)."""
        values = self.client.call(Query('stop_deceleration', (self.joint,)), 10.0)
        assert isinstance(values, dict)
        return float(values[self.joint])

    def stream_strategy(self) -> StreamStrategy | None:
        return self._strategy

    # -- intents (wait for the bus process's answer) ------------------------------------------------------
    def _intent(self, action: AxisIntentName, timeout: float | None, mode: int | str | None = None) -> None:
        wait = (timeout if timeout is not None else DEFAULT_INTENT_WAIT) + INTENT_MARGIN
        self.client.call(AxisIntent(self.joint, action, timeout, mode), wait)

    def _stop(self, action: str, timeout: float | None) -> None:
        outcome = self.client.stop(Stop((self.joint,), action, reason=action.replace('_', ' '),  # type: ignore[arg-type]
                                        timeout=timeout)).result()
        error = outcome.get(self.joint, '') if isinstance(outcome, dict) else ''
        if error:
            raise JointError(error)

    def enable(self, timeout: float | None = None) -> None:
        self._intent('enable', timeout)

    def disable(self, timeout: float | None = None) -> None:
        self._stop('disable', timeout)

    def quick_stop(self, timeout: float | None = None) -> None:
        self._stop('quick_stop', timeout)

    def halt(self, on: bool = True) -> None:
        if on:
            self._stop('halt', None)
        else:
            self._intent('resume', None)

    def reset_fault(self, timeout: float | None = None) -> None:
        self._intent('fault_reset', timeout)

    def set_mode(self, mode: int | str, timeout: float | None = None) -> None:
        self._intent('set_mode', timeout, mode)

    def home(self, timeout: float | None = None) -> None:
        self._intent('home', timeout)

    def wait_target_reached(self, timeout: float) -> None:
        self._intent('wait_target_reached', timeout)


FINAL_STATES = frozenset({'succeeded', 'superseded', 'aborted', 'cancelled'})


class HandleProxy(TrajectoryHandle):
    """A trajectory's handle in the bus process (the executor's own handle type), kept up to date
    by its HandleState reports; ``finish`` ends it here when the bus process is gone."""

    @classmethod
    def of(cls, state: HandleState) -> HandleProxy:
        handle = cls(state.id, state.joints, state.start, state.end, notes=state.notes, warnings=state.warnings)
        handle.update(state)
        return handle

    def update(self, state: HandleState) -> None:
        self.start, self.end = state.start, state.end
        if state.state in FINAL_STATES:
            self.finish(state.state, state.reason)
        elif not self.finished:
            self.state, self.reason = state.state, state.reason


class SdoTypes:
    """A node's object types from its EDS (what ``NodeRuntime.sdo.od_type`` answered)."""

    def __init__(self, config: NodeConfig) -> None:
        self.config = config

    def od_type(self, index: int, subindex: int) -> int:
        return od_data_type(self.config.od, self.config.node_id, index, subindex)


class NodeProxy:
    """A configured node as the ROS layer sees it: its configuration and family (local), its
    EDS's object types."""

    def __init__(self, config: NodeConfig, family: DriveFamily) -> None:
        self.config = config
        self.name = config.name
        self.node_id = config.node_id
        self.family = family
        self.sdo = SdoTypes(config)


class ParameterAccessProxy(ParameterAccess):
    """The family's parameter access of a node, in the bus process; each call waits for it."""

    def __init__(self, call: Callable[[ParameterCall, float], object], node_id: int, slot: int | None = None,
                 timeout: float = 30.0) -> None:
        self._call = call
        self.node_id = node_id
        self.slot = slot
        self.timeout = timeout

    def _run(self, **fields: object) -> object:
        return self._call(ParameterCall(self.node_id, slot=self.slot, **fields), self.timeout)  # type: ignore[arg-type]

    def read(self, name: str, drive_object: int = 0) -> ParameterValue:
        value = self._run(op='read', name=name, drive_object=drive_object)
        assert isinstance(value, ParameterValue)
        return value

    def write(self, name: str, value_text: str, drive_object: int = 0) -> ParameterValue:
        value = self._run(op='write', name=name, value_text=value_text, drive_object=drive_object)
        assert isinstance(value, ParameterValue)
        return value

    def save(self, drive_object: int = 0) -> str:
        return str(self._run(op='save', drive_object=drive_object))

    def stores(self, name: str) -> bool:
        return bool(self._run(op='stores', name=name))

    def safety(self, name: str) -> str | None:
        """The family's answer (the access guard refuses such a write unless access.safety_objects
        names it): without this the base class's None would open every vendor safety parameter."""
        reason = self._run(op='safety', name=name)
        return None if reason is None else str(reason)

    def for_slot(self, slot: int) -> ParameterAccess:
        return ParameterAccessProxy(self._call, self.node_id, slot, self.timeout)
