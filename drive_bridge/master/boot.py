"""Booting one node: boot-up, identity, boot SDOs, PDO mapping, heartbeat, start.

Each step names itself in a :class:`BootError` (node, step, object, abort code), so an
integrator reads what failed, not only that the boot failed.
"""
from __future__ import annotations

import time
from collections.abc import Callable

from canopen.pdo.base import PdoMap

from drive_bridge.model import MasterConfig, PdoConfig
from drive_bridge.master.node import NodeRuntime
from drive_bridge.master.pdo import od_variable
from drive_bridge.master.sdo import SdoError

NMT_START = 0x01
NMT_RESET_COMMUNICATION = 0x82
COB_ID_INVALID = 0x80000000


class BootError(Exception):
    """A boot step failed."""

    def __init__(self, node: NodeRuntime, step: str, message: str, abort_code: int = 0) -> None:
        super().__init__(f'node {node.node_id} ({node.name}) boot step "{step}": {message}')
        self.step = step
        self.abort_code = abort_code


def _sdo_step(node: NodeRuntime, step: str, action: Callable[[], object]) -> object:
    try:
        return action()
    except SdoError as exc:
        raise BootError(node, step, str(exc), exc.abort_code) from exc


def _has(node: NodeRuntime, index: int, subindex: int = 0) -> bool:
    return od_variable(node.config.od, index, subindex) is not None


def wait_for_bootup(node: NodeRuntime) -> None:
    """Reset communication and wait for the boot-up message, or (without a reset) for
    the node's boot-up or first heartbeat."""
    timeout = node.config.timeouts.boot
    if node.config.reset_communication:
        node.bootup_seen.clear()
        node.remote.nmt.send_command(NMT_RESET_COMMUNICATION)
        if not node.bootup_seen.wait(timeout):
            raise BootError(node, 'reset communication',
                            f'no boot-up message (COB-ID 0x{0x700 + node.node_id:03X}) within '
                            f'{timeout * 1000:.0f} ms of NMT reset communication')
        return
    deadline = time.monotonic() + timeout
    while node.last_heartbeat is None and not node.bootup_seen.is_set():
        if time.monotonic() > deadline:
            raise BootError(node, 'wait for boot-up',
                            f'no boot-up or heartbeat (COB-ID 0x{0x700 + node.node_id:03X}) '
                            f'within {timeout * 1000:.0f} ms')
        time.sleep(0.005)


def check_identity(node: NodeRuntime) -> None:
    expected = node.config.identity
    checks = ((0x1000, 0, 'device type', expected.device_type),
              (0x1018, 1, 'vendor-ID', expected.vendor_id),
              (0x1018, 2, 'product code', expected.product_code),
              (0x1018, 3, 'revision number', expected.revision_number),
              (0x1018, 4, 'serial number', expected.serial_number))
    for index, subindex, name, want in checks:
        if want is None:
            continue
        _type, got, _raw = _sdo_step(node, 'identity', lambda: node.sdo.read(index, subindex))  # type: ignore[misc]
        if got != want:
            raise BootError(node, 'identity', f'{name} 0x{index:04X}:{subindex:02X} is 0x{got:08X}, '
                                              f'the configuration expects 0x{want:08X}')


def run_boot_sdos(node: NodeRuntime) -> None:
    for item in node.config.boot_sdo:
        try:
            node.sdo.write(item.index, item.subindex, item.value)
        except SdoError as exc:
            where = f' ({item.where})' if item.where else ''
            raise BootError(node, 'boot SDO', f'{exc}{where}', exc.abort_code) from exc


def _write_pdo(node: NodeRuntime, pdo_map: PdoMap, config: PdoConfig, kind: str) -> None:
    pdo_map.clear()
    pdo_map.cob_id = config.cob_id
    pdo_map.trans_type = config.transmission
    if kind == 'TPDO':
        pdo_map.inhibit_time = config.inhibit_time or None
        pdo_map.event_timer = config.event_timer
        pdo_map.sync_start_value = config.sync_start or None
    for entry in config.mapping:
        pdo_map.add_variable(entry.index, entry.subindex, entry.bits)
    pdo_map.enabled = config.enabled
    pdo_map.save()
    # the bridge decodes process data itself (master/pdo.py), so canopen's own
    # per-frame handler would only cost time in the Notifier thread
    node.network.unsubscribe(config.cob_id, pdo_map.on_message)


def configure_pdos(node: NodeRuntime) -> None:
    """Write every configured PDO; disable the other PDOs the node has."""
    for kind, configs, maps, comm_base in (('RPDO', node.config.rpdo, node.remote.rpdo, 0x1400),
                                           ('TPDO', node.config.tpdo, node.remote.tpdo, 0x1800)):
        configured = {c.number for c in configs}
        for config in configs:
            step = f'{kind}{config.number} mapping'
            try:
                pdo_map = maps[config.number]
            except (KeyError, IndexError):
                raise BootError(node, step, f'the EDS has no {kind}{config.number} '
                                            f'(0x{comm_base + config.number - 1:04X})') from None
            try:
                _write_pdo(node, pdo_map, config, kind)
            except SdoError as exc:
                raise BootError(node, step, str(exc), exc.abort_code) from exc
            except Exception as exc:  # canopen raises its own SDO errors from PdoMap.save
                code = getattr(exc, 'code', 0)
                text = f'SDO abort 0x{code:08X}' if code else type(exc).__name__
                raise BootError(node, step, f'{text}: {exc}', code) from exc
        for index in range(comm_base, comm_base + 0x200):
            number = index - comm_base + 1
            if number in configured or not _has(node, index, 1):
                continue
            step = f'disable unused {kind}{number}'
            _type, cob_id, _raw = _sdo_step(node, step, lambda: node.sdo.read(index, 1))  # type: ignore[misc]
            if not int(cob_id) & COB_ID_INVALID:
                _sdo_step(node, step, lambda: node.sdo.write(index, 1, int(cob_id) | COB_ID_INVALID))


def configure_heartbeat(node: NodeRuntime, master: MasterConfig) -> None:
    if _has(node, 0x1017):
        _sdo_step(node, 'heartbeat producer',
                  lambda: node.sdo.write(0x1017, 0, node.config.heartbeat_producer_ms))
    if node.config.heartbeat_consumer and master.heartbeat_producer_ms and _has(node, 0x1016, 1):
        consumer_ms = int(master.heartbeat_producer_ms * master.heartbeat_multiplier)
        value = (master.node_id << 16) | min(consumer_ms, 0xFFFF)
        _sdo_step(node, 'heartbeat consumer', lambda: node.sdo.write(0x1016, 1, value))


def configure_sync(node: NodeRuntime, master: MasterConfig) -> None:
    """Tell the node the communication cycle period (0x1006) the bridge's SYNC runs at."""
    if master.sync_period > 0 and master.sync_producer == 'bridge' and _has(node, 0x1006):
        period_us = round(master.sync_period * 1e6)
        _sdo_step(node, 'communication cycle period', lambda: node.sdo.write(0x1006, 0, period_us))


def start_node(node: NodeRuntime) -> None:
    """NMT start, then (with a heartbeat) wait until the node reports OPERATIONAL."""
    node.remote.nmt.send_command(NMT_START)
    if not node.config.heartbeat_producer_ms:
        return
    timeout = node.config.timeouts.boot
    deadline = time.monotonic() + timeout
    while node.nmt_state != 'OPERATIONAL':
        if time.monotonic() > deadline:
            raise BootError(node, 'start', f'node still reports {node.nmt_state} {timeout * 1000:.0f} ms '
                                           'after NMT start')
        time.sleep(0.005)


def boot_node(node: NodeRuntime, master: MasterConfig, progress: Callable[[str], None]) -> None:
    """The whole boot of one node; raises BootError at the first failing step."""
    steps = (('boot-up', lambda: wait_for_bootup(node)),
             ('identity', lambda: check_identity(node)),
             ('boot SDOs', lambda: run_boot_sdos(node)),
             ('PDO mapping', lambda: configure_pdos(node)),
             ('heartbeat', lambda: configure_heartbeat(node, master)),
             ('SYNC period', lambda: configure_sync(node, master)),
             ('start', lambda: start_node(node)))
    for name, step in steps:
        progress(f'node {node.node_id} ({node.name}): {name}')
        step()
