"""Errors across the boundary: an exception in the bus process becomes a
:class:`~.reports.Failure` naming its kind, and the node process raises the same kind again,
so the ROS layer catches what it caught when the master ran in its own process."""
from __future__ import annotations

from drive_bridge.busproc.errors import BoundaryError, BusProcessLost, Busy, RemoteError
from drive_bridge.busproc.reports import Failure
from drive_bridge.families.errors import ParameterError
from drive_bridge.joint import JointError
from drive_bridge.master.errors import ObjectAddress, SdoError
from drive_bridge.streaming.errors import TrajectoryError


def failure(request_id: int, exc: BaseException) -> Failure:
    """The Failure record of ``exc`` (most specific kind first)."""
    if isinstance(exc, SdoError):
        where = exc.where
        return Failure(request_id, 'sdo', str(exc), exc.abort_code, where.node_id, where.index, where.subindex,
                       exc.reason)
    for kind, cls in (('trajectory', TrajectoryError), ('joint', JointError), ('parameter', ParameterError),
                      ('busy', Busy), ('boundary', BoundaryError), ('value', ValueError), ('timeout', TimeoutError)):
        if isinstance(exc, cls):
            return Failure(request_id, kind, str(exc), node_id=getattr(exc, 'node_id', None) or 0)
    return Failure(request_id, 'internal', f'{type(exc).__name__}: {exc}')


def exception(record: Failure) -> Exception:
    """The exception to raise in the node process for ``record``."""
    kind, message = record.kind, record.message
    if kind == 'sdo':
        error = SdoError(ObjectAddress(record.node_id, record.index, record.subindex), record.reason,
                         record.abort_code)
        return error
    if kind == 'trajectory':
        return TrajectoryError(message)
    if kind == 'joint':
        return JointError(message)
    if kind == 'parameter':
        return ParameterError(message, node_id=record.node_id or None)
    if kind == 'busy':
        return Busy(message)
    if kind == 'boundary':
        return BoundaryError(message)
    if kind == 'value':
        return ValueError(message)
    if kind == 'timeout':
        return TimeoutError(message)
    if kind == 'lost':
        return BusProcessLost(message)
    return RemoteError(kind, message)
