"""/diagnostics from a bus snapshot: one status for the bus, one per node, one per axis."""
from __future__ import annotations

import math
from collections.abc import Mapping

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from drive_bridge.joint import AxisSnapshot, DriveState
from drive_bridge.master.master import BusSnapshot
from drive_bridge.master.node import BootState, NodeSnapshot

OK, WARN, ERROR, STALE = (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR,
                          DiagnosticStatus.STALE)
PREFIX = 'drive_bridge'


def _values(**items: object) -> list[KeyValue]:
    return [KeyValue(key=k, value=str(v)) for k, v in items.items()]


def _ms(value: float) -> str:
    return f'{value * 1000:.2f} ms'


def bus_status(snapshot: BusSnapshot, node_name: str, lost: str = '',
               boundary: Mapping[str, object] | None = None, reports_dropped: int = 0) -> DiagnosticStatus:
    """``reports_dropped``: reports the bus process's full outbox dropped so far (WARN once any)."""
    status = DiagnosticStatus(name=f'{PREFIX}: bus {snapshot.channel}', hardware_id=f'can {snapshot.channel}')
    traffic = snapshot.traffic
    values = dict(node=node_name, bus_state=snapshot.bus_state, rx_frames=traffic.rx_frames,
                  tx_frames=traffic.tx_frames, frames_per_second=f'{traffic.frames_per_second:.0f}',
                  bus_load=f'{traffic.load * 100:.1f} % (nominal, no stuff bits)')
    status.level, status.message = OK, 'bus open'
    values.update(boundary or {})
    health = snapshot.health
    if health is not None:
        values.update(recv_errors=health.recv_errors, send_errors=health.send_errors,
                      error_frames=health.error_frames, last_bus_error=health.last_error)
    sync = snapshot.sync
    if sync is not None:
        values.update(sync_period=_ms(sync.period), sync_cycles=sync.cycles, sync_skipped=sync.skipped,
                      sync_interval_median=_ms(sync.interval_median), sync_interval_p99=_ms(sync.interval_p99),
                      sync_interval_max=_ms(sync.interval_max), sync_jitter_max=_ms(sync.jitter_max),
                      setpoint_lead_median=_ms(sync.lead_median), setpoint_lead_max=_ms(sync.lead_max),
                      cycle_errors=sync.hook_errors, late_setpoints=sync.late_setpoints)
        if sync.jitter_max > sync.period:
            status.level, status.message = WARN, f'SYNC jitter up to {_ms(sync.jitter_max)}'
    values.update(reports_dropped_at_boundary=reports_dropped)
    if reports_dropped:
        status.level, status.message = WARN, (
            f'{reports_dropped} reports of the bus process dropped (its outbox was full): events, EMCY, '
            'trajectory states or command refusals may be missing')
    if lost:
        status.level, status.message = ERROR, lost
    elif snapshot.bus_state == 'STARTING':
        status.level, status.message = WARN, 'bus process starting'
    elif snapshot.bus_state not in ('ACTIVE', 'CLOSED'):
        status.level, status.message = ERROR, f'CAN controller {snapshot.bus_state}'
    status.values = _values(**values)
    return status


def node_status(node: NodeSnapshot) -> DiagnosticStatus:
    status = DiagnosticStatus(name=f'{PREFIX}: node {node.name}', hardware_id=f'canopen node {node.node_id}')
    if node.boot_state is BootState.OPERATIONAL and node.available:
        status.level, status.message = OK, 'operational'
    elif node.boot_state in (BootState.FAILED, BootState.LOST, BootState.STALE):
        status.level = ERROR
        status.message = node.boot_error or node.boot_state.value
    else:
        status.level, status.message = WARN, node.boot_state.value
    last = node.emcy[-1] if node.emcy else None
    status.values = _values(
        nmt_state=node.nmt_state, boot_state=node.boot_state.value, boot_attempts=node.boot_attempts,
        boot_error=node.boot_error, liveness=node.liveness,
        heartbeat_age='never' if node.heartbeat_age is None else _ms(node.heartbeat_age),
        guarding_toggle_errors=node.guarding_toggle_errors,
        sdo_errors=node.sdo_errors, last_sdo_error=node.last_sdo_error, pdo_errors=node.pdo_errors,
        last_pdo_error=node.last_pdo_error, emcy_count=len(node.emcy), emcy_suppressed=node.emcy_suppressed,
        last_emcy='' if last is None else f'0x{last.code:04X} {last.text}')
    return status


def axis_status(axis: AxisSnapshot) -> DiagnosticStatus:
    status = DiagnosticStatus(name=f'{PREFIX}: axis {axis.joint}',
                              hardware_id=f'canopen node {axis.node_id} axis {axis.slot}')
    if not axis.available:
        status.level, status.message = ERROR, f'unavailable (NMT {axis.nmt_state})'
    elif axis.drive_state is DriveState.FAULT or (axis.fault and axis.drive_state is DriveState.STOPPING):
        emcy = f': 0x{axis.last_emcy.code:04X} {axis.last_emcy.text}' if axis.last_emcy else ''
        status.level, status.message = ERROR, f'{axis.state_label}{emcy}'
    elif axis.setpoint_refused:
        status.level, status.message = ERROR, axis.setpoint_refused
    elif axis.command_stale or axis.warning:
        status.level = WARN
        status.message = axis.message if axis.command_stale else f'{axis.state_label}, drive warning bit set'
    else:
        status.level, status.message = OK, axis.state_label
    status.values = _values(
        state=axis.state.label, drive_state=axis.drive_state.label, mode=axis.mode_name,
        requested_mode=axis.requested_mode,
        statusword=f'0x{axis.statusword:04X}', controlword=f'0x{axis.controlword:04X}',
        position='' if math.isnan(axis.position) else f'{axis.position:.6f}',
        velocity='' if math.isnan(axis.velocity) else f'{axis.velocity:.6f}',
        effort='' if math.isnan(axis.effort) else f'{axis.effort:.6f}',
        halted=axis.halted, following_error=axis.following_error, internal_limit=axis.internal_limit,
        last_emcy='' if axis.last_emcy is None else f'0x{axis.last_emcy.code:04X} {axis.last_emcy.text}',
        message=axis.message)
    return status


def diagnostics(snapshot: BusSnapshot, node_name: str, lost: str = '',
                boundary: Mapping[str, object] | None = None, reports_dropped: int = 0) -> DiagnosticArray:
    """``lost``: why the bus process is gone ('' while it runs); ``boundary``: its figures;
    ``reports_dropped``: reports its full outbox dropped."""
    array = DiagnosticArray()
    array.status = [bus_status(snapshot, node_name, lost, boundary, reports_dropped),
                    *(node_status(n) for n in snapshot.nodes),
                    *(axis_status(a) for a in snapshot.axes)]
    return array
