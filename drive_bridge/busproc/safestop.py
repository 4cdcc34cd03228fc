"""What the bus process does when its node process is gone (killed, crashed, closed its side):
bring every enabled axis to a controlled stop, in parallel, and say what it did.

Per axis (its ``on_node_loss`` settings, ``model.NodeLossConfig``):
1. the trajectories end and the joint driver's quick stop is given (CiA 402: the drive ramps
   down with its quick-stop deceleration);
2. the bridge waits until the axis is at rest (|velocity| below :data:`REST_VELOCITY` of its
   limit, or the drive has left operation by itself), at most the time its stop deceleration
   needs plus :data:`REST_MARGIN`. A drive that runs on by itself (its family's
   ``boot.runs_on_without_master``: once this process is gone nothing stops it) gets its family's
   stop besides (``FamilyNode.stop_run_on``: by SDO every ``run_on.SDO_PERIOD``, while the
   joint driver's stop goes by PDO every cycle), and leaving operation is not the end for it:
   the bridge waits until the family reports the drive at rest, at most :data:`MAX_STOP_TIME`
   (it stops on its own ramp, which the bridge does not know);
3. ``action: disable`` (default): after ``brake_delay`` (the holding brake engages) operation is
   disabled; ``action: hold``: the axis stays in quick stop active, holding torque (a vertical
   axis does not drop), for as long as the bus process runs.
Nothing is enabled again by the bus process: a new node starts a new bus process, whose boot
leaves every axis disabled until a client enables it.
"""
from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Iterable, Mapping

from drive_bridge.joint import DriveState, JointDriver
from drive_bridge.master.node import NodeRuntime
from drive_bridge.master.run_on import SDO_PERIOD
from drive_bridge.streaming.executor import TrajectoryExecutor

log = logging.getLogger('drive_bridge.busproc')

REST_VELOCITY = 0.01  # of the joint's max_velocity (or rad/s, m/s without one): "at rest"
REST_MARGIN = 1.0  # s beyond the computed stop time before the bridge disables anyway
MAX_STOP_TIME = 10.0  # s: the longest a stop is waited for
QUICK_STOP_TIMEOUT = 0.5  # s for the drive to show quick stop active

FamilyStop = Callable[[bool], bool]  # FamilyNode.stop_run_on of one node: (by_sdo) -> at rest


def family_stops(nodes: Iterable[NodeRuntime]) -> dict[str, FamilyStop]:
    """Per joint of a drive that runs on by itself (``boot.runs_on_without_master``): its family's stop."""
    return {axis.joint: node.family_node.stop_run_on
            for node in nodes if node.family.boot.runs_on_without_master for axis in node.config.axes}


def stop_all(axes: Mapping[str, JointDriver], executor: TrajectoryExecutor | None, reason: str,
             run_on: Mapping[str, FamilyStop] | None = None) -> list[str]:
    """Stop every enabled axis as described above (blocks until done); returns one line per
    axis saying what happened. Axes that hold stay held when this returns. ``run_on``: the
    family's stop of each joint whose drive runs on by itself (:func:`family_stops`)."""
    if executor is not None:
        try:
            executor.stop(list(axes), reason, 'aborted')
        except Exception as exc:  # the axis stops go on
            log.error('ending the trajectories: %r', exc)
    lines: dict[str, str] = {}
    stops = run_on or {}
    threads = [threading.Thread(target=_stop_one, args=(axis, lines, stops.get(joint)),
                                name=f'drive_bridge-safestop-{joint}', daemon=True) for joint, axis in axes.items()]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(MAX_STOP_TIME + 5)
    return [lines.get(joint, f'{joint}: stop did not finish') for joint in axes]


def _stop_one(axis: JointDriver, lines: dict[str, str], family_stop: FamilyStop | None) -> None:
    joint = axis.joint
    try:
        lines[joint] = _stop(axis, family_stop)
    except Exception as exc:
        lines[joint] = f'{joint}: stop failed: {exc}'


def _stop(axis: JointDriver, family_stop: FamilyStop | None) -> str:
    joint = axis.joint
    if not axis.available:
        return f'{joint}: unavailable, nothing sent'
    if axis.drive_state not in (DriveState.ENABLED, DriveState.STOPPING):
        return f'{joint}: not enabled ({axis.drive_state.label}), nothing to stop'
    settings = axis.config.node_loss
    velocity = abs(axis.snapshot().velocity)
    try:
        axis.quick_stop(QUICK_STOP_TIMEOUT)
    except Exception as exc:  # not confirmed: still wait for rest, then disable
        log.warning('%s: quick stop not confirmed: %s', joint, exc)
    rest = REST_VELOCITY * (axis.config.limits.max_velocity or 1.0)
    deceleration = axis.stop_deceleration()
    needed = velocity / deceleration if deceleration > 0 and math.isfinite(velocity) else MAX_STOP_TIME
    bound = min(MAX_STOP_TIME, needed + REST_MARGIN)
    if family_stop is not None:  # it stops on its own ramp, which the bridge does not know
        bound = MAX_STOP_TIME
        deadline = time.monotonic() + bound
        at_rest, how = _family_stop(axis, family_stop, deadline, rest), "quick stop and its family's stop"
    else:
        deadline = time.monotonic() + bound
        how = 'quick stop'
        at_rest = False
        while time.monotonic() < deadline:
            snapshot = axis.snapshot()
            if snapshot.drive_state not in (DriveState.ENABLED, DriveState.STOPPING) or not snapshot.available:
                return f'{joint}: quick stop, the drive left operation by itself ({snapshot.state_label})'
            if abs(snapshot.velocity) <= rest:
                at_rest = True
                break
            time.sleep(0.01)
    stopped = 'at rest' if at_rest else f'not at rest after {bound:.1f} s'
    if settings.action == 'hold':
        return f'{joint}: {how}, {stopped}, held in quick stop active (on_node_loss: hold)'
    time.sleep(settings.brake_delay)
    axis.disable()
    return f'{joint}: {how}, {stopped}, disabled after the {settings.brake_delay * 1000:.0f} ms brake delay'


def _family_stop(axis: JointDriver, family_stop: FamilyStop, deadline: float, rest: float) -> bool:
    """The family's stop of a drive that runs on by itself, by SDO every SDO_PERIOD, until the
    family reports the drive at rest (or, while the SDO fails, its velocity is below ``rest``):
    whether it came to rest before ``deadline``. The joint driver's stop goes by PDO meanwhile."""
    failed = False
    while True:
        try:
            if family_stop(True):
                return True
        except Exception as exc:  # the PDO stop goes on; the velocity decides
            if not failed:
                failed = True
                log.warning("%s: its family's stop by SDO failed (%s); still sent by PDO", axis.joint, exc)
            snapshot = axis.snapshot()
            if snapshot.available and abs(snapshot.velocity) <= rest:
                return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(min(SDO_PERIOD, max(0.0, deadline - time.monotonic())))
