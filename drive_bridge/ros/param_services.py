"""Services ``~/param_read``, ``~/param_write``, ``~/param_save``: drive parameters by the names
their vendor gives them, through the drive family's parameter access
(:mod:`drive_bridge.families.parameters`, obtained with ``Master.parameter_access``).

The target is a joint (the node of its axis) or, when ``joint`` is empty, a configured
``node_id``; ``drive_object`` selects a drive object of nodes that have several (0: the
joint's own, or the node's first). Unknown
joints and nodes, families without parameter access, every ParameterError and a refusal by the
bus config's ``access`` rules (:mod:`drive_bridge.ros.access`; a write of a parameter the family
says stores or restores, e.g. a save command, counts as a save) answer ``success = False`` with
the error in ``message``. As in :mod:`drive_bridge.ros.services`,
handlers await the blocking work in a thread pool, in a reentrant callback group, so the
executor never waits on the bus.
"""
from __future__ import annotations

import concurrent.futures
from collections.abc import Callable
from typing import Any, TypeVar

from drive_bridge_interfaces.srv import ParamRead, ParamSave, ParamWrite
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node

from drive_bridge.busproc.client import BusClient
from drive_bridge.families.errors import ParameterError
from drive_bridge.families.parameters import ParameterAccess, ParameterValue
from drive_bridge.ros.access import AccessGuard
from drive_bridge.ros.errors import RequestRefused
from drive_bridge.ros.pool import BoundedPool, in_pool
from drive_bridge.ros.services import MAX_PENDING_REQUESTS

T = TypeVar('T')


class ParameterServices:
    """Registers the three services on ``node``; ``pool``: the thread pool to run them in
    (default: one of its own, shut down by :meth:`close`)."""

    def __init__(self, node: Node, master: BusClient,
                 pool: concurrent.futures.ThreadPoolExecutor | None = None) -> None:
        self.node = node
        self.master = master
        self.guard = AccessGuard(master.config.access, master)
        self._own_pool = pool is None
        self.pool = pool or BoundedPool(4, MAX_PENDING_REQUESTS, 'drive_bridge-param')
        group = ReentrantCallbackGroup()
        self.services = [
            node.create_service(ParamRead, '~/param_read', self.param_read, callback_group=group),
            node.create_service(ParamWrite, '~/param_write', self.param_write, callback_group=group),
            node.create_service(ParamSave, '~/param_save', self.param_save, callback_group=group),
        ]

    def close(self) -> None:
        if self._own_pool:
            self.pool.shutdown(wait=False, cancel_futures=True)

    async def _in_pool(self, work: Callable[[], T]) -> T:
        """Run blocking work in the pool and await it without blocking the executor."""
        return await in_pool(self.node, self.pool, work)

    # -- targets --------------------------------------------------------------------------------
    def _node_id(self, joint: str, node_id: int) -> int:
        """The target's node id: the node of ``joint``, else ``node_id``."""
        if joint:
            axis = self.master.axes.get(joint)
            if axis is None:
                raise ParameterError(f'unknown joint {joint!r}; this bus has {", ".join(self.master.axes) or "none"}')
            return axis.node_id
        if not node_id:
            raise ParameterError('no target: give a joint, or a node_id (1..127) when joint is empty')
        return node_id

    def _access(self, joint: str, node_id: int) -> ParameterAccess:
        """The parameter access of the target's node (as the joint's axis slot sees it)."""
        access = self.master.parameter_access(node_id)
        return access.for_slot(self.master.axes[joint].config.slot) if joint else access

    async def _run(self, joint: str, node_id: int, check: Callable[[int, ParameterAccess | None], None],
                   action: Callable[[ParameterAccess], T], response: Any) -> T | None:
        """The action's result, or None with ``response`` set to the failure. ``check`` applies
        the access rules to the target node before anything reaches it: first without the
        node's parameter access (None), then with it."""
        prefix = f'joint {joint}: ' if joint else ''

        def work() -> T:
            target = self._node_id(joint, node_id)
            check(target, None)
            access = self._access(joint, target)
            check(target, access)
            return action(access)
        try:
            result = await self._in_pool(work)
        except (ParameterError, RequestRefused, TimeoutError) as exc:
            response.success, response.message = False, prefix + str(exc)
            return None
        except Exception as exc:  # a family's bug must still answer, and say what happened
            response.success, response.message = False, f'{prefix}{type(exc).__name__}: {exc}'
            return None
        response.success = True
        response.message = prefix
        return result

    def _check_read(self, node_id: int, access: ParameterAccess | None) -> None:
        if access is None:
            self.guard.param_read(node_id)

    def _check_save(self, node_id: int, access: ParameterAccess | None) -> None:
        if access is None:
            self.guard.param_save(node_id)

    @staticmethod
    def _fill(response: Any, value: ParameterValue) -> None:
        response.value_text = value.value_text
        response.is_number = value.value is not None
        response.value = float(value.value) if value.value is not None else 0.0
        response.unit = value.unit
        response.has_range = value.has_range
        response.minimum = float(value.minimum) if value.minimum is not None else 0.0
        response.maximum = float(value.maximum) if value.maximum is not None else 0.0
        response.access = value.access
        response.save_needed = value.save_needed

    @staticmethod
    def _summary(value: ParameterValue, written: bool) -> str:
        notes = [value.note] if value.note else []
        if written and value.save_needed:
            notes.append('lost at power-off or reset unless saved (~/param_save)')
        return value.describe() + (f' ({"; ".join(notes)})' if notes else '')

    # -- handlers -------------------------------------------------------------------------------
    async def param_read(self, request: ParamRead.Request, response: ParamRead.Response) -> ParamRead.Response:
        value = await self._run(request.joint, request.node_id, self._check_read,
                                lambda access: access.read(request.parameter, request.drive_object), response)
        if value is not None:
            self._fill(response, value)
            response.message += self._summary(value, written=False)
        return response

    async def param_write(self, request: ParamWrite.Request, response: ParamWrite.Response) -> ParamWrite.Response:
        def check(node_id: int, access: ParameterAccess | None) -> None:
            self.guard.param_write(node_id, access, request.parameter)
        value = await self._run(request.joint, request.node_id, check,
                                lambda access: access.write(request.parameter, request.value, request.drive_object),
                                response)
        if value is not None:
            self._fill(response, value)
            response.message += 'written: ' + self._summary(value, written=True)
        return response

    async def param_save(self, request: ParamSave.Request, response: ParamSave.Response) -> ParamSave.Response:
        done = await self._run(request.joint, request.node_id, self._check_save,
                               lambda access: access.save(request.drive_object), response)
        if done is not None:
            response.message += done
        return response
