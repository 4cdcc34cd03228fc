"""Booting one node: boot-up, identity, the family's first steps, boot SDOs, PDOs,
supervision (heartbeat or node guarding), SYNC period, the family's last steps, start.

Each step names itself in a :class:`BootError` (node, step, object, abort code), so an
integrator reads what failed, not only that the boot failed. What differs between drive
lines (how boot-up shows, how PDOs are set, extra steps) the node's family answers.
"""
from __future__ import annotations

import time
from collections.abc import Callable

from canopen.pdo.base import PdoMap

from drive_bridge.cia301.nmt import NmtState
from drive_bridge.errors import DriveBridgeError
from drive_bridge.families import BootDetection, Liveness, PdoConfiguration
from drive_bridge.families.ports import BootStep
from drive_bridge.master.errors import BootError, SdoError
from drive_bridge.master.guarding import configure_guarding as write_guarding
from drive_bridge.master.node import NodeRuntime
from drive_bridge.master.pdo import od_variable
from drive_bridge.model import MasterConfig, PdoConfig

NMT_START = 0x01
NMT_RESET_COMMUNICATION = 0x82
COB_ID_INVALID = 0x80000000


PROBE_INTERVAL = 0.05  # s between SDO probes of a node that announces no boot-up
PROBE_TIMEOUT = 0.1
SYNC_WINDOW = 0x1007  # synchronous window length, µs (CiA 301)


# SDO abort classes a repeated identical write always gets again (CiA 301): access (0x0601),
# object or sub-index absent (0x0602, 0x0609 0011), PDO mapping (0x0604), value range (0x0609)
_PERMANENT_ABORT_CLASSES = frozenset({0x0601, 0x0602, 0x0604, 0x0609})


def repeats_identically(error: BootError, previous: BootError | None) -> bool:
    """The boot refusal is the same as the last attempt's and of a kind that does not go
    away by retrying (a value the drive's object refuses, an object it lacks)."""
    return (previous is not None and error.abort_code != 0 and error.abort_code == previous.abort_code
            and str(error) == str(previous) and error.abort_code >> 16 in _PERMANENT_ABORT_CLASSES)


def _sdo_step(node: NodeRuntime, step: str, action: Callable[[], object]) -> object:
    try:
        return action()
    except SdoError as exc:
        raise BootError(node, step, str(exc), exc.abort_code) from exc


def _sdo_read(node: NodeRuntime, step: str, index: int, subindex: int) -> int:
    """An integer object, read as a boot step."""
    try:
        value = node.sdo.read(index, subindex)[1]
    except SdoError as exc:
        raise BootError(node, step, str(exc), exc.abort_code) from exc
    if not isinstance(value, int):
        raise BootError(node, step, f'0x{index:04X}:{subindex:02X} is not an integer ({value!r})')
    return value


def _sdo_write(node: NodeRuntime, step: str, index: int, subindex: int, value: int) -> None:
    try:
        node.sdo.write(index, subindex, value)
    except SdoError as exc:
        raise BootError(node, step, str(exc), exc.abort_code) from exc


def _has(node: NodeRuntime, index: int, subindex: int = 0) -> bool:
    return od_variable(node.config.od, index, subindex) is not None


def _announcement(node: NodeRuntime) -> str:
    detection = node.family.boot.detection
    if detection is BootDetection.EMCY:
        return f'boot-up EMCY (COB-ID 0x{0x80 + node.node_id:03X})'
    if detection is BootDetection.PROBE:
        return 'answer to an SDO probe of 0x1000'
    return f'boot-up message (COB-ID 0x{0x700 + node.node_id:03X})'


def _probe(node: NodeRuntime, deadline: float) -> bool:
    """SDO-read 0x1000 until the node answers or the deadline passes."""
    while time.monotonic() < deadline:
        try:
            node.sdo.read(0x1000, 0)
            return True
        except SdoError as exc:
            if exc.abort_code:  # an abort is an answer: the node is up
                return True
        time.sleep(PROBE_INTERVAL)
    return False


def wait_for_bootup(node: NodeRuntime) -> None:
    """Reset communication and wait for the node's boot-up announcement (the family says
    which: boot-up frame, an EMCY, or none, then an SDO probe); without a reset, for the
    announcement, a heartbeat, or (no heartbeat) an answer to an SDO probe."""
    timeout = node.config.timeouts.boot
    detection = node.family.boot.detection
    node.restart_guarding()
    if node.config.reset_communication:
        node.bootup_seen.clear()
        node.remote.nmt.send_command(NMT_RESET_COMMUNICATION)
        if detection is BootDetection.PROBE:
            up = _probe(node, time.monotonic() + timeout)
        else:
            up = node.bootup_seen.wait(timeout)
        if not up:
            raise BootError(node, 'reset communication',
                            f'no {_announcement(node)} within {timeout * 1000:.0f} ms of NMT reset communication')
        return
    deadline = time.monotonic() + timeout
    if node.liveness is not Liveness.HEARTBEAT:
        if not (node.bootup_seen.is_set() or _probe(node, deadline)):
            raise BootError(node, 'wait for boot-up', f'no {_announcement(node)} and no answer to an SDO '
                                                      f'probe of 0x1000 within {timeout * 1000:.0f} ms')
        return
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
        got = _sdo_read(node, 'identity', index, subindex)
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
    """Free mapping through canopen's PdoMap (communication and mapping parameters); only
    the communication sub-indices the family says the node has are written."""
    subs = node.family.pdo.comm_subindices
    pdo_map.clear()
    pdo_map.cob_id = config.cob_id
    pdo_map.trans_type = config.transmission
    if kind == 'TPDO':
        pdo_map.inhibit_time = (config.inhibit_time or None) if 3 in subs else None
        comm = 0x1800 + config.number - 1
        pdo_map.event_timer = config.event_timer if 5 in subs and _has(node, comm, 5) else None
        pdo_map.sync_start_value = (config.sync_start or None) if 6 in subs else None
    for entry in config.mapping:
        pdo_map.add_variable(entry.index, entry.subindex, entry.bits)
    pdo_map.enabled = config.enabled
    pdo_map.save()
    # the bridge decodes process data itself (master/pdo.py), so canopen's own
    # per-frame handler would only cost time in the Notifier thread
    node.network.unsubscribe(config.cob_id, pdo_map.on_message)


def _select_pdo(node: NodeRuntime, pdo_map: PdoMap, config: PdoConfig, kind: str, comm_index: int) -> None:
    """A predefined PDO chosen by the family's SDO writes, then its COB-ID and transmission
    type (and, for TPDOs, the other sub-indices the node has). A PDO the family does not
    select (None: e.g. one of a drive's free PDOs) is mapped freely."""
    selection = node.family.select_pdo(kind, config)
    if selection is None:
        _write_pdo(node, pdo_map, config, kind)
        return
    for index, subindex, value in selection:
        node.sdo.write(index, subindex, value)
    subs = node.family.pdo.comm_subindices
    cob_id = config.cob_id | (0 if config.enabled else COB_ID_INVALID)
    writes = [(1, cob_id), (2, config.transmission)]
    if kind == 'TPDO':
        writes += [(sub, value) for sub, value in ((3, config.inhibit_time), (5, config.event_timer),
                                                   (6, config.sync_start)) if sub in subs and value]
    for subindex, value in writes:
        node.sdo.write(comm_index, subindex, value)


def _writable(node: NodeRuntime, index: int, subindex: int) -> bool:
    var = od_variable(node.config.od, index, subindex)
    return var is not None and 'w' in var.access_type


def _write_by_sdo(node: NodeRuntime, config: PdoConfig, kind: str, comm_index: int) -> None:
    """A PDO whose EDS makes its COB-ID or its mapping read-only (canopen's PdoMap writes
    both): the parameters the EDS lets us write, the COB-ID invalid meanwhile if it can be."""
    map_index = comm_index + 0x200
    cob_writable = _writable(node, comm_index, 1)
    if cob_writable:
        node.sdo.write(comm_index, 1, config.cob_id | COB_ID_INVALID)
    writes = [(2, config.transmission)] + ([(5, config.event_timer)] if kind == 'TPDO' else [])
    for subindex, value in writes:
        if subindex in node.family.pdo.comm_subindices and _writable(node, comm_index, subindex):
            node.sdo.write(comm_index, subindex, value)
    if _writable(node, map_index, 1):
        node.sdo.write(map_index, 0, 0)
        for number, entry in enumerate(config.mapping, start=1):
            node.sdo.write(map_index, number, entry.index << 16 | entry.subindex << 8 | entry.bits)
        node.sdo.write(map_index, 0, len(config.mapping))
    if config.enabled and cob_writable:
        node.sdo.write(comm_index, 1, config.cob_id)


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
                comm_index = comm_base + config.number - 1
                if not _writable(node, comm_index, 1) or not _writable(node, comm_index + 0x200, 1):
                    _write_by_sdo(node, config, kind, comm_index)
                elif node.family.pdo.configuration is PdoConfiguration.SELECT_BY_NUMBER:
                    _select_pdo(node, pdo_map, config, kind, comm_base + config.number - 1)
                else:
                    _write_pdo(node, pdo_map, config, kind)
            except SdoError as exc:
                raise BootError(node, step, str(exc), exc.abort_code) from exc
            except Exception as exc:  # canopen raises its own SDO errors from PdoMap.save
                code = getattr(exc, 'code', 0)
                text = f'SDO abort 0x{code:08X}' if code else type(exc).__name__
                raise BootError(node, step, f'{text}: {exc}', code) from exc
        for index in range(comm_base, comm_base + 0x200):
            number = index - comm_base + 1
            if number in configured or not _writable(node, index, 1):
                continue
            step = f'disable unused {kind}{number}'
            cob_id = int(_sdo_read(node, step, index, 1))
            if not cob_id & COB_ID_INVALID:
                _sdo_write(node, step, index, 1, cob_id | COB_ID_INVALID)


def configure_heartbeat(node: NodeRuntime, master: MasterConfig) -> None:
    if node.liveness is Liveness.GUARDING:
        return  # configure_guarding: the two exclude each other
    if _has(node, 0x1017):
        _sdo_step(node, 'heartbeat producer',
                  lambda: node.sdo.write(0x1017, 0, node.config.heartbeat_producer_ms))
    if node.config.heartbeat_consumer and master.heartbeat_producer_ms and _has(node, 0x1016, 1):
        consumer_ms = int(master.heartbeat_producer_ms * master.heartbeat_multiplier)
        value = (master.node_id << 16) | min(consumer_ms, 0xFFFF)
        _sdo_step(node, 'heartbeat consumer', lambda: node.sdo.write(0x1016, 1, value))


def configure_sync(node: NodeRuntime, master: MasterConfig) -> None:
    """Tell the node the communication cycle period (0x1006) the bridge's (or kernel's) SYNC runs at."""
    if master.sends_sync and master.sync_producer in ('bridge', 'kernel') and _has(node, 0x1006):
        period_us = round(master.sync_period * 1e6)
        _sdo_step(node, 'communication cycle period', lambda: node.sdo.write(0x1006, 0, period_us))
    configure_sync_window(node, master)


def configure_sync_window(node: NodeRuntime, master: MasterConfig) -> None:
    """Write the synchronous window length (0x1007, µs) to a node that has it, and read it
    back: a drive that keeps another window discards set-points the bridge counts as on time."""
    if master.sync_window is None or not _has(node, SYNC_WINDOW):
        return
    step = 'synchronous window'
    window_us = round(master.sync_window * 1e6)
    _sdo_write(node, step, SYNC_WINDOW, 0, window_us)
    answered = _sdo_read(node, step, SYNC_WINDOW, 0)
    if answered != window_us:
        raise BootError(node, step, f'0x{SYNC_WINDOW:04X}:00 (synchronous window length) reads {answered} µs '
                                    f'after writing {window_us} µs (master.sync_window)')


def start_node(node: NodeRuntime) -> None:
    """NMT start, then wait until the node reports OPERATIONAL (heartbeat or guarding
    reply); a node without either is taken as operational once started."""
    node.remote.nmt.send_command(NMT_START)
    if node.liveness is Liveness.NONE:
        node.nmt_state = NmtState.OPERATIONAL
        return
    timeout = node.config.timeouts.boot
    deadline = time.monotonic() + timeout
    if node.liveness is Liveness.GUARDING:
        node.nmt_state = NmtState.UNKNOWN  # the next guarding reply tells
    while node.nmt_state is not NmtState.OPERATIONAL:
        if time.monotonic() > deadline:
            raise BootError(node, 'start', f'node still reports {node.nmt_state} {timeout * 1000:.0f} ms '
                                           'after NMT start')
        time.sleep(0.005)


def _family_step(node: NodeRuntime, step: BootStep) -> tuple[str, Callable[[], None]]:
    name, action = step

    def run() -> None:
        try:
            action(node)
        except BootError:
            raise
        except SdoError as exc:
            raise BootError(node, name, str(exc), exc.abort_code) from exc
        except DriveBridgeError as exc:
            raise BootError(node, name, str(exc)) from exc
    return name, run


def configure_guarding(node: NodeRuntime) -> None:
    """Node guarding: 0x1017 = 0 first (many drives drop guarding once a heartbeat time is
    set), then guard time 0x100C and life time factor 0x100D."""
    if node.liveness is not Liveness.GUARDING:
        return
    _sdo_step(node, 'node guarding', lambda: write_guarding(
        node.sdo_write, node.has_object, node.config.guard_time_ms, node.config.life_time_factor))
    node.guard_active = True  # the supervisor polls it from now on


def boot_node(node: NodeRuntime, master: MasterConfig, progress: Callable[[str], None]) -> None:
    """The whole boot of one node; raises BootError at the first failing step."""
    family = node.family_node
    steps: tuple[tuple[str, Callable[[], None]], ...] = (
             ('boot-up', lambda: wait_for_bootup(node)),
             *(_family_step(node, step) for step in family.boot_steps_early(node)),
             ('identity', lambda: check_identity(node)),
             *(_family_step(node, step) for step in family.boot_steps_before(node)),
             ('boot SDOs', lambda: run_boot_sdos(node)),
             ('PDO mapping', lambda: configure_pdos(node)),
             ('heartbeat', lambda: configure_heartbeat(node, master)),
             ('node guarding', lambda: configure_guarding(node)),
             ('SYNC period', lambda: configure_sync(node, master)),
             *(_family_step(node, step) for step in family.boot_steps_after(node)),
             ('start', lambda: start_node(node)))
    for name, step in steps:
        progress(f'node {node.node_id} ({node.name}): {name}')
        step()
