"""What the bus process does when its node process is gone (killed, crashed, closed its side):
bring every enabled axis to a controlled stop, in parallel, and say what it did.

Per axis (its ``on_node_loss`` settings, ``model.NodeLossConfig``):
1. the trajectories end and the joint driver's quick stop is given (CiA 402: the drive ramps
   down with its quick-stop deceleration; a drive that runs on by itself: its family's stop);
2. the bridge waits until the axis is at rest (|velocity| below :data:`REST_VELOCITY` of its
   limit, or the drive has left operation by itself), at most the time its stop deceleration
   needs plus :data:`REST_MARGIN`;
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
from collections.abc import Mapping

from drive_bridge.joint import DriveState, JointDriver
from drive_bridge.streaming.executor import TrajectoryExecutor

log = logging.getLogger('drive_bridge.busproc')

REST_VELOCITY = 0.01  # of the joint's max_velocity (or rad/s, m/s without one): "at rest"
REST_MARGIN = 1.0  # s beyond the computed stop time before the bridge disables anyway
MAX_STOP_TIME = 10.0  # s: the longest a stop is waited for
QUICK_STOP_TIMEOUT = 0.5  # s for the drive to show quick stop active


def stop_all(axes: Mapping[str, JointDriver], executor: TrajectoryExecutor | None, reason: str) -> list[str]:
    """Stop every enabled axis as described above (blocks until done); returns one line per
    axis saying what happened. Axes that hold stay held when this returns."""
    if executor is not None:
        try:
            executor.stop(list(axes), reason, 'aborted')
        except Exception as exc:  # the axis stops go on
            log.error('ending the trajectories: %r', exc)
    lines: dict[str, str] = {}
    threads = [threading.Thread(target=_stop_one, args=(axis, lines), name=f'drive_bridge-safestop-{joint}',
                                daemon=True) for joint, axis in axes.items()]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(MAX_STOP_TIME + 5)
    return [lines.get(joint, f'{joint}: stop did not finish') for joint in axes]


def _stop_one(axis: JointDriver, lines: dict[str, str]) -> None:
    joint = axis.joint
    try:
        lines[joint] = _stop(axis)
    except Exception as exc:
        lines[joint] = f'{joint}: stop failed: {exc}'


def _stop(axis: JointDriver) -> str:
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
    deadline = time.monotonic() + min(MAX_STOP_TIME, needed + REST_MARGIN)
    at_rest = False
    while time.monotonic() < deadline:
        snapshot = axis.snapshot()
        if snapshot.drive_state not in (DriveState.ENABLED, DriveState.STOPPING) or not snapshot.available:
            return f'{joint}: quick stop, the drive left operation by itself ({snapshot.state_label})'
        if abs(snapshot.velocity) <= rest:
            at_rest = True
            break
        time.sleep(0.01)
    stopped = 'at rest' if at_rest else f'not at rest after {min(MAX_STOP_TIME, needed + REST_MARGIN):.1f} s'
    if settings.action == 'hold':
        return f'{joint}: quick stop, {stopped}, held in quick stop active (on_node_loss: hold)'
    time.sleep(settings.brake_delay)
    axis.disable()
    return f'{joint}: quick stop, {stopped}, disabled after the {settings.brake_delay * 1000:.0f} ms brake delay'
