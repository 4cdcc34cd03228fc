"""Services: typed SDO, NMT, and per-joint axis control.

SDO and NMT requests pass the bus config's ``access`` rules first (:mod:`drive_bridge.ros.access`):
a refusal answers ``success = False`` with the rule that refused it in ``message``.

Handlers wait on the bus (SDO round trips, state transitions), so they run in a thread
pool and the executor stays free: each handler is a coroutine awaiting the pool's
result, in a callback group of its own (the default group would stall the node's timers
while a handler waits). ``~/quick_stop``, ``~/halt`` and ``~/disable`` never enter that pool:
they await the bus process's stop lane directly, so no other call can hold them up.
"""
from __future__ import annotations

import concurrent.futures
import math
from collections.abc import Callable
from typing import Any, TypeVar

from drive_bridge_interfaces.msg import SdoValue
from drive_bridge_interfaces.srv import AxisCommand, NmtCommand, SdoRead, SdoWrite, SetMode
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node

from drive_bridge.busproc.client import BusClient
from drive_bridge.busproc.executor import ExecutorProxy
from drive_bridge.busproc.intents import Stop, StopName
from drive_bridge.busproc.proxies import AxisProxy
from drive_bridge.cia301.nmt import NMT_COMMANDS
from drive_bridge.joint import JointError
from drive_bridge.master.errors import ObjectAddress, SdoError
from drive_bridge.master.sdo import type_name
from drive_bridge.ros.access import AccessGuard
from drive_bridge.ros.conversions import python_to_sdo_value, sdo_value_to_python
from drive_bridge.ros.errors import RequestRefused
from drive_bridge.ros.message_checks import check_float
from drive_bridge.ros.pool import BoundedPool, await_future, in_pool

T = TypeVar('T')
SERVICE_WORKERS = 8
# requests running or waiting at once (all services of the node); more are refused at once
MAX_PENDING_REQUESTS = 32
AxisAction = Callable[[AxisProxy, float | None], str | None]
# on the stop lane (service name -> the stop and the reason its trajectories end with)
STOPS: dict[str, tuple[StopName, str]] = {'quick_stop': ('quick_stop', 'quick stop'), 'halt': ('halt', 'halted'),
                                          'disable': ('disable', 'disabled')}
# the longest wait a request's ``timeout`` may ask for (s): a worker blocked longer serves no one
MAX_TIMEOUT = 30.0
MAX_HOMING_TIMEOUT = 300.0  # a homing run crosses the whole axis at search speed


def request_timeout(service: str, value: float) -> float | None:
    """A request's ``timeout`` (0: the configured default, None) checked as a finite number in
    0..MAX_TIMEOUT (homing: MAX_HOMING_TIMEOUT); RequestRefused names the field and the bound."""
    bound = MAX_HOMING_TIMEOUT if service == 'home' else MAX_TIMEOUT
    if not isinstance(value, float) or not math.isfinite(value) or not 0.0 <= value <= bound:
        raise RequestRefused(f'{service}: timeout {value!r} s refused: give a finite number of seconds in '
                             f'0..{bound:g} (0 = the configured default)')
    return value if value > 0 else None


class BridgeServices:
    def __init__(self, node: Node, master: BusClient, executor: ExecutorProxy) -> None:
        self.node = node
        self.master = master
        self.executor = executor
        self.guard = AccessGuard(master.config.access, master)
        self.pool = BoundedPool(SERVICE_WORKERS, MAX_PENDING_REQUESTS, 'drive_bridge-srv')
        # per-joint work of one request fans out here, never into self.pool (no nested waits)
        self.joint_pool = concurrent.futures.ThreadPoolExecutor(max_workers=SERVICE_WORKERS,
                                                                thread_name_prefix='drive_bridge-axis')
        self.active = True
        group = ReentrantCallbackGroup()
        node.create_service(SdoRead, '~/sdo_read', self.sdo_read, callback_group=group)
        node.create_service(SdoWrite, '~/sdo_write', self.sdo_write, callback_group=group)
        node.create_service(NmtCommand, '~/nmt', self.nmt, callback_group=group)
        actions: dict[str, AxisAction] = {
            'enable': self._enable, 'resume': lambda a, t: a.halt(False),
            'fault_reset': lambda a, t: a.reset_fault(t), 'recover': self._recover, 'home': lambda a, t: a.home(t),
        }
        for name, action in actions.items():
            node.create_service(AxisCommand, f'~/{name}', self._axis_handler(name, action), callback_group=group)
        for name in STOPS:  # a group of their own: never behind the others' callbacks
            node.create_service(AxisCommand, f'~/{name}', self._stop_handler(name),
                                callback_group=ReentrantCallbackGroup())
        node.create_service(SetMode, '~/set_mode', self.set_mode, callback_group=group)

    async def _in_pool(self, work: Callable[[], T]) -> T:
        """Run blocking work in the pool and await it without blocking the executor."""
        return await in_pool(self.node, self.pool, work)

    # -- SDO and NMT -------------------------------------------------------------------------
    def _resolve_type(self, node_id: int, index: int, subindex: int, data_type: int) -> int:
        if data_type != SdoValue.AUTO:
            return data_type
        node = self.master.node_by_id(node_id)
        if node is None:
            raise SdoError(ObjectAddress(node_id, index, subindex),
                           'node is not in the bus configuration, so its EDS is unknown: give data_type')
        return node.sdo.od_type(index, subindex)

    async def sdo_read(self, request: SdoRead.Request, response: SdoRead.Response) -> SdoRead.Response:
        def work() -> None:
            self.guard.sdo_read(request.node_id, request.index, request.subindex)
            data_type = self._resolve_type(request.node_id, request.index, request.subindex, request.data_type)
            used, value, raw = self.master.sdo_read(request.node_id, request.index, request.subindex, data_type)
            response.value = python_to_sdo_value(used, value, raw)
            response.message = (f'node {request.node_id} 0x{request.index:04X}:{request.subindex:02X} = '
                                f'{value!r} ({type_name(used)})')
        return await self._sdo(work, response)

    async def sdo_write(self, request: SdoWrite.Request, response: SdoWrite.Response) -> SdoWrite.Response:
        def work() -> None:
            self.guard.sdo_write(request.node_id, request.index, request.subindex)
            data_type = self._resolve_type(request.node_id, request.index, request.subindex,
                                           request.value.data_type)
            value = sdo_value_to_python(request.value, data_type)
            if isinstance(value, float):
                check_float('value.float_value', value)
            self.master.sdo_write(request.node_id, request.index, request.subindex, value, data_type)
            response.message = (f'node {request.node_id} 0x{request.index:04X}:{request.subindex:02X} := '
                                f'{value!r} ({type_name(data_type)})')
        return await self._sdo(work, response)

    async def _sdo(self, work: Callable[[], None], response: Any) -> Any:
        try:
            await self._in_pool(work)
            response.success = True
        except SdoError as exc:
            response.success, response.abort_code, response.message = False, exc.abort_code, str(exc)
        except (ValueError, RequestRefused, TimeoutError) as exc:
            response.success, response.message = False, str(exc)
        return response

    async def nmt(self, request: NmtCommand.Request, response: NmtCommand.Response) -> NmtCommand.Response:
        def work() -> None:
            self.guard.nmt(request.node_id)
            self.master.nmt(request.command, request.node_id)
        try:  # in the pool: a command leaving OPERATIONAL first stops the node's axes (blocking)
            await self._in_pool(work)
        except (ValueError, RequestRefused, TimeoutError) as exc:
            response.success, response.message = False, str(exc)
            return response
        target = 'all nodes' if request.node_id == 0 else f'node {request.node_id}'
        response.success = True
        response.message = f'NMT {NMT_COMMANDS[request.command]} sent to {target}'
        return response

    # -- axes -------------------------------------------------------------------------------
    def _joints(self, names: list[str]) -> list[str]:
        unknown = [n for n in names if n not in self.master.axes]
        if unknown:
            raise JointError(f'unknown joint(s) {", ".join(unknown)}; this bus has {", ".join(self.master.axes)}')
        return list(names) or list(self.master.axes)

    def _enable(self, axis: AxisProxy, timeout: float | None) -> None:
        if not self.active:
            raise JointError('the bridge is deactivated: activate it before enabling axes')
        axis.enable(timeout)

    def _stop_handler(self, name: str):
        action, reason = STOPS[name]

        async def handle(request: AxisCommand.Request, response: AxisCommand.Response) -> AxisCommand.Response:
            try:
                names = self._joints(list(request.joints))
            except JointError as exc:
                response.success, response.message, response.failed = False, str(exc), list(request.joints)
                return response
            try:
                timeout = request_timeout(name, request.timeout)
                outcome = await await_future(self.node, self.master.stop(Stop(tuple(names), action, reason,
                                                                             timeout=timeout)))
            except (RequestRefused, TimeoutError) as exc:
                response.success, response.message, response.failed = False, str(exc), names
                return response
            assert isinstance(outcome, dict)
            failed = [j for j in names if outcome.get(j)]
            response.success, response.failed = not failed, failed
            done = f'{name}: done for {", ".join(names)}'
            response.message = '; '.join(outcome[j] for j in failed) if failed else done
            return response
        return handle

    def _recover(self, axis: AxisProxy, timeout: float | None) -> None:
        axis.reset_fault(timeout)
        self._enable(axis, timeout)

    def _axis_handler(self, name: str, action: AxisAction):
        async def handle(request: AxisCommand.Request, response: AxisCommand.Response) -> AxisCommand.Response:
            try:
                timeout = request_timeout(name, request.timeout)
            except RequestRefused as exc:
                response.success, response.message, response.failed = False, str(exc), list(request.joints)
                return response
            return await self._for_joints(name, list(request.joints),
                                          lambda axis: action(axis, timeout), response)
        return handle

    async def set_mode(self, request: SetMode.Request, response: SetMode.Response) -> SetMode.Response:
        mode = request.mode.strip()
        if not mode:
            response.success, response.message = False, 'set_mode: no mode given'
            return response
        try:
            timeout = request_timeout('set_mode', request.timeout)
        except RequestRefused as exc:
            response.success, response.message, response.failed = False, str(exc), list(request.joints)
            return response

        def change(axis: AxisProxy) -> None:
            self.executor.stop([axis.joint], 'mode change')
            axis.set_mode(mode, timeout)
        return await self._for_joints(f'set_mode {request.mode}', list(request.joints), change, response)

    async def _for_joints(self, name: str, joints: list[str], action: Callable[[AxisProxy], object],
                          response: Any) -> Any:
        """Run an action on each joint in parallel; report every joint's outcome."""
        try:
            names = self._joints(joints)
        except JointError as exc:
            response.success, response.message, response.failed = False, str(exc), list(joints)
            return response

        def one(joint: str) -> str | None:
            try:
                action(self.master.axes[joint])
            except (JointError, SdoError, ValueError, RequestRefused, TimeoutError) as exc:
                return str(exc)
            return None

        def all_joints() -> dict[str, str | None]:
            return dict(zip(names, self.joint_pool.map(one, names))) if len(names) > 1 else {names[0]: one(names[0])}
        try:
            outcome = await self._in_pool(all_joints)
        except RequestRefused as exc:
            response.success, response.message, response.failed = False, str(exc), names
            return response
        failed = [j for j, error in outcome.items() if error]
        response.success = not failed
        response.failed = failed
        response.message = '; '.join(error for error in outcome.values() if error) if failed else \
            f'{name}: done for {", ".join(names)}'
        return response

