"""One ``nodes.<name>`` section: family, EDS, identity, boot SDOs, PDOs, axes, timeouts.

Checks that need the object dictionary run only when it loaded, so a missing EDS is
one error and not one per object.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from canopen import ObjectDictionary

from drive_bridge.cia402 import objects as obj
from drive_bridge.config import keys
from drive_bridge.config.axes import AxisDraft, check_axis_objects, parse_axes
from drive_bridge.config.bootcheck import check_heartbeat_limits, fit_supervision
from drive_bridge.config.eds import read_object_dictionary
from drive_bridge.config.errors import EdsError, Issues, Loc
from drive_bridge.config.guarding import Supervision, check_guarding_objects, parse_supervision
from drive_bridge.config.pdo import PdoDraft, family_drafts, parse_pdo_table, resolve_pdo
from drive_bridge.config.reader import Section, describe, suggestion
from drive_bridge.config.sdo import parse_boot_sdo
from drive_bridge.families import DriveFamily, family_names, get_family
from drive_bridge.families.interface import PdoPlan
from drive_bridge.model import Identity, MasterConfig, NodeConfig, Timeouts

NODE_NAME = re.compile(r'[A-Za-z][A-Za-z0-9_]*')
BUS_CONFIG_PATH = '@BUS_CONFIG_PATH@'  # ros2_canopen's build-time placeholder: the bus.yml's directory


@dataclass
class NodeContext:
    """What every node needs from the rest of the file."""

    issues: Issues
    file: str
    base_dir: Path  # the config file's directory
    dcf_dir: Path  # options.dcf_path, else base_dir
    master: MasterConfig
    defaults: Section | None


@dataclass
class NodeDraft:
    """A parsed node; ``config`` is None when errors left it incomplete."""

    name: str
    loc: Loc
    node_id: int | None
    config: NodeConfig | None = None
    axes: list[AxisDraft] = field(default_factory=list)
    pdos: list[PdoDraft] = field(default_factory=list)

    @property
    def id_loc(self) -> Loc:
        return self.loc.key('node_id')


def resolve_dir(text: str, base_dir: Path) -> Path:
    path = Path(text.replace(BUS_CONFIG_PATH, str(base_dir))).expanduser()
    return path if path.is_absolute() else base_dir / path


def _family(node: Section) -> tuple[DriveFamily | None, bool]:
    """(family, whether the node follows a ros2_canopen 402 driver's defaults)."""
    issues = node.issues
    driver = node.get_str('driver') if 'driver' in node else None
    if 'family' in node:
        if driver is not None:
            issues.warn(node.loc('driver'), f'ignored: family ({node.loc("family").path}) takes precedence')
        name = node.get_str('family', choices=family_names())
        return (get_family(name) if name else None), False
    if driver is None:
        return (get_family('generic_402') if 'driver' not in node else None), False
    mapped = keys.DRIVER_FAMILIES.get(driver)
    if mapped is None:
        known = ', '.join(keys.DRIVER_FAMILIES)
        issues.error(node.loc('driver'), f"unknown ros2_canopen driver {describe(driver)}"
                                         f'{suggestion(driver, keys.DRIVER_FAMILIES)}; drive_bridge maps {known}; '
                                         f'or give family: one of {", ".join(family_names())}')
        return None, False
    return get_family(mapped), mapped == 'generic_402'


def _eds_path(ctx: NodeContext, node: Section, family: DriveFamily, axis_count: int) -> tuple[Path | None, Loc]:
    if 'dcf' not in node:
        if 'dcf_path' in node:
            ctx.issues.warn(node.loc('dcf_path'), 'not used: the node gives no dcf')
        shipped = family.eds_for(axis_count)
        if shipped is None:
            ctx.issues.error(node.where, f"no dcf given, and family '{family.name}' ships no EDS; "
                                         'give dcf: <file>.eds (or .dcf)')
        return shipped, node.where
    name = node.get_str('dcf')
    if name is None:
        return None, node.loc('dcf')
    if name == keys.TODO:
        shipped = family.eds_for(axis_count)
        fallback = (f"; or remove dcf to use family '{family.name}''s own EDS ({shipped.name}), if it is this device's"
                    if shipped is not None else '')
        ctx.issues.error(node.loc('dcf'), "TODO: give this drive's EDS or DCF (the vendor's file for its identity); "
                                          f'`drive-bridge scan --eds DIR` names the one that matches{fallback}')
        return None, node.loc('dcf')
    base = ctx.dcf_dir
    if 'dcf_path' in node:
        directory = node.get_str('dcf_path')
        base = resolve_dir(directory, ctx.base_dir) if directory else base
    path = Path(name).expanduser()
    return (path if path.is_absolute() else base / path), node.loc('dcf')


def _load_od(ctx: NodeContext, path: Path, loc: Loc, node_id: int) -> ObjectDictionary | None:
    try:
        od, notes = read_object_dictionary(path, node_id)
    except EdsError as exc:
        ctx.issues.error(loc, str(exc))
        return None
    for note in notes:
        ctx.issues.warn(loc, note)
    return od


def _timeouts(node: Section) -> Timeouts:
    base = Timeouts()

    def seconds(key: str, default: float) -> float:
        value = node.get_number(key, gt=0)
        return default if value is None else value / 1000.0

    homing = seconds('homing_timeout_ms', base.homing)
    if 'homing_timeout_seconds' in node:
        if 'homing_timeout_ms' in node:
            node.issues.error(node.loc('homing_timeout_seconds'), 'give either homing_timeout_ms or '
                                                                  'homing_timeout_seconds, not both')
        homing = node.get_number('homing_timeout_seconds', base.homing, gt=0) or base.homing
    return Timeouts(boot=seconds('boot_timeout_ms', base.boot),
                    boot_retries=node.get_int('boot_retries', base.boot_retries, lo=0) or 0,
                    boot_retry_interval=seconds('boot_retry_interval_ms', base.boot_retry_interval),
                    sdo=seconds('sdo_timeout_ms', base.sdo),
                    sdo_retries=node.get_int('sdo_retries', base.sdo_retries, lo=0) or 0,
                    state_switch=seconds('state_switch_timeout_ms', base.state_switch),
                    mode_switch=seconds('mode_switch_timeout_ms', base.mode_switch),
                    homing=homing,
                    command_timeout=seconds('command_timeout_ms', base.command_timeout))


def _heartbeats(ctx: NodeContext, node: Section, supervision: Supervision) -> bool:
    consumer = node.get_bool('heartbeat_consumer', True)
    if supervision.heartbeat_producer_ms == 0 and not supervision.guarded and ctx.master.heartbeat_consumer:
        ctx.issues.warn(node.loc('heartbeat_producer'), 'the node sends no heartbeat, so the master cannot '
                                                        'monitor it (master.heartbeat_consumer is true)')
    if consumer and ctx.master.heartbeat_producer_ms == 0:
        ctx.issues.warn(node.where, 'heartbeat_consumer is true but the master sends no heartbeat '
                                    '(master.heartbeat_producer is 0); the node will not monitor it')
    return consumer


def _axes_loc(node: Section) -> Loc:
    return next((node.loc(k) for k in ('axes', 'num_channels', 'channel_names') if k in node), node.where)


def _pdos(ctx: NodeContext, node: Section, name: str, node_id: int, family: DriveFamily,
          axes: list[AxisDraft], defaults_allowed: bool,
          od: ObjectDictionary | None) -> tuple[list[PdoDraft], PdoPlan | None]:
    synchronous = ctx.master.sends_sync
    transmission = 1 if synchronous else 255
    drafts: list[PdoDraft] = []
    explicit = {kind: parse_pdo_table(ctx.issues, node.get(kind), node.loc(kind), kind, node_id, name, transmission)
                for kind in ('rpdo', 'tpdo') if kind in node}
    plan = None
    if len(explicit) < 2 and defaults_allowed:
        try:
            if od is not None and not explicit:
                plan = family.plan_pdos(node_id, [d.axis for d in axes], synchronous, od)
                rpdos, tpdos = plan.rpdos, plan.tpdos
            elif od is not None:  # the config gives one kind: the family's map of the other, for this EDS
                rpdos, tpdos = family.default_pdos_for_eds(node_id, [d.axis for d in axes], synchronous, od)
            else:
                rpdos, tpdos = family.default_pdos(node_id, [d.axis for d in axes], synchronous)
            defaults = {'rpdo': rpdos, 'tpdo': tpdos}
        except ValueError as exc:
            ctx.issues.error(node.where, f"family '{family.name}' has no default PDO map for this node: {exc}")
            defaults = {}
        for kind, configs in defaults.items():
            if kind not in explicit:
                explicit[kind] = family_drafts(configs, kind, node.where, family.name, name)  # type: ignore[arg-type]
    for kind in ('rpdo', 'tpdo'):
        drafts.extend(explicit.get(kind, []))
    return drafts, plan


def _own_section(ctx: NodeContext, name: str, value: Any) -> Section | None:
    loc = Loc('nodes').key(name)
    if not NODE_NAME.fullmatch(name):
        ctx.issues.error(loc, "expected a node name of letters, digits and '_' starting with a letter "
                              f'(it becomes part of ROS names), got {describe(name)}')
    own = Section.of(ctx.issues, value, loc, 'a node section (a mapping with at least node_id)')
    if own is None:
        return None
    own.check_keys(keys.NODE, keys.NODE_IGNORED)
    return Section(ctx.issues, {k: v for k, v in own.data.items() if k in keys.NODE}, loc)


def parse_node(ctx: NodeContext, name: str, value: Any) -> NodeDraft | None:
    own = _own_section(ctx, name, value)
    if own is None:
        return None
    node = Section.merged(own, ctx.defaults, via=f"node '{name}'")
    issues = ctx.issues
    node_id = node.get_int('node_id', lo=1, hi=127) if node.require('node_id', 'the node id 1..127') else None
    draft = NodeDraft(name, node.where, node_id)
    family, ros_defaults = _family(node)
    if family is None:
        return draft
    draft.axes = parse_axes(node, name, family, ros_defaults, ctx.file)
    explicit_pdos = 'rpdo' in node and 'tpdo' in node
    too_many = len(draft.axes) > family.axes.max_count
    if too_many and not explicit_pdos:
        issues.error(_axes_loc(node), f"{len(draft.axes)} axes, but family '{family.name}' drives at most "
                                      f'{family.axes.max_count} with its default PDO map; give explicit rpdo and tpdo '
                                      f'for up to {obj.MAX_AXES}')
    eds_path, eds_loc = _eds_path(ctx, node, family, len(draft.axes))
    od = _load_od(ctx, eds_path, eds_loc, node_id or 1) if eds_path is not None else None
    eds_name = eds_path.name if eds_path is not None else ''
    if od is not None:  # e.g. a modular EDS that describes one drive object: the family adds the others
        for problem in family.prepare_object_dictionary(od, [d.axis.slot for d in draft.axes]):
            issues.error(eds_loc, f'{eds_name}: {problem}')
    sdo_items = node.get_list('sdo', 'a list of {index, sub_index, value}') or []
    boot_sdo = parse_boot_sdo(issues, sdo_items, od, eds_name, ctx.file)
    identity = Identity(**{key: node.get_int(key, lo=0, hi=0xFFFFFFFF, allow_str=True) for key in keys.IDENTITY})
    supervision = parse_supervision(node, name, family.name, family.boot.has_heartbeat)
    if od is not None:
        supervision = fit_supervision(node, od, eds_name, supervision)
    consumer = _heartbeats(ctx, node, supervision)
    reset = node.get_bool('reset_communication', family.boot.nmt_reset_communication)
    timeouts = _timeouts(node)
    plan = None
    if node_id is not None:
        draft.pdos, plan = _pdos(ctx, node, name, node_id, family, draft.axes, not too_many, od)
    if plan is not None:  # the family's map leaves the axes as it says (modes it can stream, estimates)
        draft.axes = [replace(d, axis=a) for d, a in zip(draft.axes, plan.axes, strict=True)]
    if od is None or node_id is None:
        return draft
    # a wrong axis count or slot already explains why the family's map cannot fit: say it once
    axes_fit = False
    if not (too_many and not explicit_pdos):
        axes_fit = all([check_axis_objects(issues, od, eds_name, axis, family) for axis in draft.axes]) \
            if family.axes.has_cia402 else True
    draft.pdos = [resolve_pdo(issues, od, eds_name, p) if axes_fit or not p.from_family else p
                  for p in draft.pdos]
    pdo_loc = next((node.loc(k) for k in ('rpdo', 'tpdo') if k in node), node.where)
    for problem in family.check_pdos([p.config for p in draft.pdos if p.kind == 'rpdo'],
                                     [p.config for p in draft.pdos if p.kind == 'tpdo'],
                                     [d.axis.slot for d in draft.axes]):
        issues.error(pdo_loc, problem)
    check_guarding_objects(node, supervision, od, eds_name, sdo_items)
    check_heartbeat_limits(node, od, eds_name, supervision, consumer, ctx.master,
                           Loc('master').key('heartbeat_producer'))
    draft.config = NodeConfig(
        name=name, node_id=node_id, family=family.name, od=od, eds_path=eds_path, identity=identity,
        boot_sdo=boot_sdo, rpdo=tuple(p.config for p in draft.pdos if p.kind == 'rpdo'),
        tpdo=tuple(p.config for p in draft.pdos if p.kind == 'tpdo'),
        heartbeat_producer_ms=supervision.heartbeat_producer_ms, heartbeat_consumer=consumer,
        guard_time_ms=supervision.guard_time_ms, life_time_factor=supervision.life_time_factor,
        reset_communication=reset, timeouts=timeouts,
        axes=tuple(d.axis for d in draft.axes), polled=plan.polled if plan else (),
        pdo_summary=plan.summary if plan else '', where=f'{ctx.file}: {node.where.path}')
    return draft
