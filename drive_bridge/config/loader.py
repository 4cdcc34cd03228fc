"""YAML bus configuration -> BusConfig: the top-level sections and the checks that
span nodes (ids, joints, COB-IDs). Every problem is collected, then raised once."""
from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import can

from drive_bridge.config import keys
from drive_bridge.config.access import parse_access
from drive_bridge.config.busbudget import budget_verdict, bus_budget
from drive_bridge.config.cycle import sync_window_problem
from drive_bridge.config.errors import Issues, Loc
from drive_bridge.config.nodes import NodeContext, NodeDraft, parse_node, resolve_dir
from drive_bridge.config.pdo import check_cob_ids
from drive_bridge.config.reader import Section, describe, suggestion
from drive_bridge.config.record import parse_record, parse_trajectory
from drive_bridge.config.yamlio import parse_yaml, read_yaml
from drive_bridge.model import BusConfig, BusInterface, MasterConfig, SimulationConfig
from drive_bridge.transport import INTERFACES

_BUS_ARGS = ('interface', 'channel', 'bitrate')


def _options(sec: Section | None, base_dir: Path) -> tuple[Path, float | None]:
    """(directory of relative dcf paths, lely's global heartbeat multiplier)."""
    if sec is None:
        return base_dir, None
    sec.check_keys(keys.OPTIONS)
    dcf_dir = base_dir
    text = sec.get_str('dcf_path')
    if text is not None:
        dcf_dir = resolve_dir(text, base_dir)
        if not dcf_dir.is_dir():
            sec.issues.error(sec.loc('dcf_path'), f'directory not found (looked for {dcf_dir})')
    return dcf_dir, sec.get_number('heartbeat_multiplier', ge=1)


def _master(sec: Section | None, multiplier: float | None) -> tuple[MasterConfig, int | None]:
    """The master and ros2_canopen's ``baudrate`` (kbit/s), if given."""
    base = MasterConfig()
    fallback = multiplier if multiplier is not None else base.heartbeat_multiplier
    if sec is None:
        return MasterConfig(heartbeat_multiplier=fallback), None
    sec.check_keys(keys.MASTER, keys.MASTER_IGNORED)
    node_id = sec.get_int('node_id', base.node_id, lo=1, hi=127) or base.node_id
    sync_us = sec.get_int('sync_period', 4000, lo=0)
    master = MasterConfig(
        node_id=node_id,
        sync_period=(sync_us if sync_us is not None else 4000) / 1e6,
        sync_producer=sec.get_str('sync_producer', base.sync_producer, choices=('bridge', 'external', 'kernel')),  # type: ignore[arg-type]
        heartbeat_producer_ms=sec.get_int('heartbeat_producer', base.heartbeat_producer_ms, lo=0, hi=0xFFFF) or 0,
        heartbeat_consumer=sec.get_bool('heartbeat_consumer', base.heartbeat_consumer),
        heartbeat_multiplier=sec.get_number('heartbeat_multiplier', fallback, ge=1) or fallback,
        sync_window=_sync_window(sec),
        realtime_priority=(sec.get_int('realtime_priority', None, lo=1, hi=99)
                           if sec.get('realtime_priority') is not None else None))
    problem = sync_window_problem(master)
    if problem:
        sec.issues.error(sec.loc('sync_window'), problem)
    return master, sec.get_int('baudrate', lo=1, hi=1000)


def _sync_window(sec: Section) -> float | None:
    """master.sync_window (µs) in seconds; null or 0 (CiA 301: not used, lely's default) = not written."""
    if sec.get('sync_window') is None:
        return None
    window_us = sec.get_int('sync_window', lo=0)
    return window_us / 1e6 if window_us else None


def _bus(sec: Section | None, baudrate_kbit: int | None, issues: Issues) -> BusInterface:
    from_master = baudrate_kbit * 1000 if baudrate_kbit is not None else None
    if sec is None:
        return BusInterface(bitrate=from_master or BusInterface().bitrate)
    sec.check_keys(keys.BUS)
    interface = sec.get_str('interface', 'virtual', choices=sorted({*can.VALID_INTERFACES, *INTERFACES})) or 'virtual'
    channel: str | int = 'drive_bridge'
    if 'channel' in sec:
        raw = sec.get('channel')
        if (isinstance(raw, str) and raw) or (isinstance(raw, int) and not isinstance(raw, bool)):
            channel = raw
        else:
            issues.error(sec.loc('channel'), f'expected a channel name or number (can0, PCAN_USBBUS1, 0), '
                                             f'got {describe(raw)}')
    bitrate: int | None = from_master or BusInterface().bitrate
    if 'bitrate' in sec:
        bitrate = None if sec.get('bitrate') is None else sec.get_int('bitrate', lo=1)
        if bitrate is not None and from_master is not None and bitrate != from_master:
            issues.error(Loc('master.baudrate'), f'{baudrate_kbit} kbit/s disagrees with bus.bitrate {bitrate} bit/s; '
                                                 'give only bus.bitrate')
    options: dict[str, Any] = {}
    extra = sec.section('options', 'a mapping of extra can.Bus keyword arguments')
    if extra is not None:
        for key in extra:
            if key in _BUS_ARGS:
                issues.error(extra.loc(key), f'give {key} as bus.{key}, not among the options')
            else:
                options[key] = extra.get(key)
    return BusInterface(interface=interface, channel=channel, bitrate=bitrate, options=options)


def _defaults(sec: Section | None) -> Section | None:
    if sec is None:
        return None
    allowed = [k for k in keys.NODE if k != 'node_id']
    sec.check_keys(allowed, keys.NODE_IGNORED, {'node_id': 'node_id must be given in each node, not in defaults'})
    return Section(sec.issues, {k: v for k, v in sec.data.items() if k in allowed}, sec.where)


def _check_node_ids(issues: Issues, drafts: list[NodeDraft], master: MasterConfig,
                    master_sec: Section | None) -> set[str]:
    """Reports node ids used twice; returns the names of the nodes with such an id."""
    given = master_sec is not None and 'node_id' in master_sec
    seen: dict[int, NodeDraft] = {}
    clashing: set[str] = set()
    for draft in drafts:
        node_id = draft.node_id
        if node_id is None:
            continue
        if node_id == master.node_id:
            where = 'master.node_id' if given else 'the default of master.node_id'
            issues.error(draft.id_loc, f'{node_id} is the master\'s node id ({where}); '
                                       'give the node or the master another id')
            clashing.add(draft.name)
        elif node_id in seen:
            first = seen[node_id]
            issues.error(draft.id_loc, f"{node_id} is already used by node '{first.name}' ({first.id_loc.path})")
            clashing.add(draft.name)
        else:
            seen[node_id] = draft
    return clashing


def _check_joints(issues: Issues, drafts: list[NodeDraft]) -> None:
    seen: dict[str, Loc] = {}
    for draft in drafts:
        for axis in draft.axes:
            joint = axis.axis.joint
            if joint in seen:
                issues.error(axis.joint_loc, f"joint '{joint}' is already used by {seen[joint].path}")
            else:
                seen[joint] = axis.joint_loc


def _simulation(sec: Section | None, names: list[str], bus: BusInterface) -> SimulationConfig:
    if sec is None:
        return SimulationConfig()
    sec.check_keys(keys.SIMULATION)
    enabled = sec.get_bool('enabled', False)
    if enabled and bus.interface != 'virtual':
        sec.issues.error(sec.loc('enabled'), f"simulated drives run only on bus.interface 'virtual', "
                                             f"got '{bus.interface}'; disable the simulation or use 'virtual'")
    options: dict[str, Mapping[str, Any]] = {}
    table = sec.section('nodes', 'a mapping of node name -> simulator options')
    for name in table or ():
        assert table is not None
        if name not in names:
            listed = ', '.join(names) or 'none'
            sec.issues.error(table.loc(name), f'unknown node{suggestion(name, names)}; the nodes are: {listed}')
            continue
        node_options = Section.of(sec.issues, table.get(name), table.loc(name), 'a mapping of simulator options')
        if node_options is not None:
            options[name] = dict(node_options.data)
    return SimulationConfig(enabled=enabled, options=options)


def parse_bus_config(data: Mapping[str, Any], source: str, base_dir: Path,
                     path: Path | None = None) -> BusConfig:
    """A BusConfig from already parsed YAML. ``source`` names the file in messages;
    relative paths in it are taken from ``base_dir``. Raises ConfigError listing every problem."""
    issues = Issues(source)
    root = Section.of(issues, data, Loc(), 'a mapping with the sections ' + ', '.join(keys.TOP))
    if root is None:
        issues.raise_if_errors()
    assert root is not None
    root.check_keys(keys.TOP)
    base_dir = Path(base_dir)
    dcf_dir, multiplier = _options(root.section('options'), base_dir)
    master_sec = root.section('master')
    master, baudrate = _master(master_sec, multiplier)
    bus_sec = root.section('bus')
    bus = _bus(bus_sec, baudrate, issues)
    allow_overload = bus_sec.get_bool('allow_overload', False) if bus_sec is not None else False
    context = NodeContext(issues, source, base_dir, dcf_dir, master, _defaults(root.section('defaults')))
    drafts: list[NodeDraft] = []
    names: list[str] = []
    if root.require('nodes', 'a mapping of node name -> node section'):
        table = root.section('nodes', 'a mapping of node name -> node section')
        if table is not None and not table.data:
            issues.warn(Loc('nodes'), 'no nodes: the bridge will only run the master (SYNC, heartbeat)')
        names = list(table or ())
        for name in names:
            draft = parse_node(context, name, table.get(name))  # type: ignore[union-attr]
            if draft is not None:
                drafts.append(draft)
    clashing = _check_node_ids(issues, drafts, master, master_sec)
    _check_joints(issues, drafts)
    # a node with a clashing id clashes in every predefined COB-ID too: reported once above
    check_cob_ids(issues, [pdo for draft in drafts if draft.name not in clashing for pdo in draft.pdos])
    simulation = _simulation(root.section('simulation'), names, bus)
    access = parse_access(root.section('access'), {d.name: d.node_id for d in drafts if d.node_id is not None})
    record = parse_record(root.section('record'))
    trajectory = parse_trajectory(root.section('trajectory'))
    nodes = tuple(d.config for d in drafts if d.config is not None)
    if not issues.error_count:
        warning, error = budget_verdict(bus_budget(bus.bitrate, master, nodes), allow_overload)
        if error:
            issues.error(Loc('bus'), error)
        elif warning:
            issues.warn(Loc('bus'), warning)
    issues.raise_if_errors()
    return BusConfig(bus=bus, master=master, nodes=nodes, simulation=simulation, access=access, record=record,
                     trajectory=trajectory,
                     path=path, warnings=issues.warning_texts(), allow_overload=allow_overload)


def load_bus_config(path: str | os.PathLike[str]) -> BusConfig:
    """The bus configuration in the YAML file ``path`` (relative paths in it are taken
    from its directory). Raises ConfigError listing every problem."""
    file = Path(path)
    data = read_yaml(file, str(path))
    return parse_bus_config(data, str(path), file.resolve().parent, path=file)


def load_bus_config_text(text: str, source: str = '<string>',
                         base_dir: str | os.PathLike[str] | None = None) -> BusConfig:
    """The bus configuration in YAML ``text`` (e.g. a ROS parameter), with the same strict
    YAML reading as files; relative paths are taken from ``base_dir`` (default: cwd)."""
    data = parse_yaml(text, source)
    return parse_bus_config(data, source, Path(base_dir) if base_dir is not None else Path.cwd())
