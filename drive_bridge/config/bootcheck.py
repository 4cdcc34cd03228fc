"""Boot steps the EDS says cannot succeed, caught at load time with the key to change:
a heartbeat time beyond 0x1017's limits, a heartbeat the node cannot produce (no 0x1017: such
a node is guarded instead when the config leaves supervision open), a consumer entry beyond
0x1016's limits. A file whose limit contradicts CiA 301's layout of 0x1016 (producer node
id in bits 16-23) is named with a warning, and CiA 301 is followed."""
from __future__ import annotations

from canopen import ObjectDictionary

from drive_bridge.config.errors import Loc
from drive_bridge.config.guarding import Supervision
from drive_bridge.config.odcheck import lookup
from drive_bridge.config.reader import Section
from drive_bridge.model import MasterConfig

HEARTBEAT_PRODUCER = 0x1017
HEARTBEAT_CONSUMER = 0x1016
GUARD_TIME, LIFE_TIME_FACTOR = 0x100C, 0x100D
DEFAULT_GUARDING = Supervision(0, 100, 3)  # ms, factor: when the node has no heartbeat objects
_CONSUMER_VALUE_MAX = 0x00FFFFFF  # CiA 301: reserved (8) | node id (8) | time in ms (16)


def fit_supervision(node: Section, od: ObjectDictionary, eds_name: str, supervision: Supervision) -> Supervision:
    """The node's supervision, as its EDS allows it."""
    if not supervision.heartbeat_producer_ms or HEARTBEAT_PRODUCER in od:
        return supervision
    if node.own('heartbeat_producer') or 'heartbeat_producer' in node:
        node.issues.error(node.loc('heartbeat_producer'), f'{eds_name} has no 0x1017 (producer heartbeat time): '
                                                          'the node sends no heartbeat; set heartbeat_producer: 0 '
                                                          'and guard_time_ms (e.g. 100)')
        return supervision
    if GUARD_TIME in od and LIFE_TIME_FACTOR in od:
        node.issues.warn(node.where, f'{eds_name} has no 0x1017 (producer heartbeat time): the node is guarded '
                                     f'instead (guard_time_ms {DEFAULT_GUARDING.guard_time_ms}, life_time_factor '
                                     f'{DEFAULT_GUARDING.life_time_factor})')
        return DEFAULT_GUARDING
    node.issues.warn(node.where, f'{eds_name} has neither 0x1017 nor 0x100C/0x100D: the node cannot be supervised')
    return Supervision(0)


def check_heartbeat_limits(node: Section, od: ObjectDictionary, eds_name: str, supervision: Supervision,
                           consumer: bool, master: MasterConfig, master_loc: Loc) -> None:
    """The heartbeat writes of the boot against the EDS's limits."""
    issues = node.issues
    produced = lookup(od, eds_name, HEARTBEAT_PRODUCER, 0).var if HEARTBEAT_PRODUCER in od else None
    if produced is not None and supervision.heartbeat_producer_ms and isinstance(produced.max, int) \
            and supervision.heartbeat_producer_ms > produced.max:
        issues.error(node.loc('heartbeat_producer'), f'{supervision.heartbeat_producer_ms} ms is above the HighLimit '
                                                     f'{produced.max} of 0x1017 in {eds_name}')
    entry = lookup(od, eds_name, HEARTBEAT_CONSUMER, 1).var if HEARTBEAT_CONSUMER in od else None
    if entry is None or not consumer or not master.heartbeat_producer_ms:
        return
    time_ms = min(int(master.heartbeat_producer_ms * master.heartbeat_multiplier), 0xFFFF)
    value = master.node_id << 16 | time_ms
    if isinstance(entry.max, int) and entry.max < 1 << 16:
        issues.warn(node.where, f'{eds_name} [1016sub1]: HighLimit 0x{entry.max:X} contradicts CiA 301\'s layout of '
                                '0x1016:01 (producer node id in bits 16-23, time in bits 0-15): no entry naming a '
                                f'producer would fit; following CiA 301 (writing 0x{value:08X})')
    elif isinstance(entry.max, int) and value > min(entry.max, _CONSUMER_VALUE_MAX):
        issues.error(master_loc, f'the heartbeat consumer entry 0x{value:08X} (master node {master.node_id}, '
                                 f'{time_ms} ms) is above the HighLimit 0x{entry.max:X} of 0x1016:01 in {eds_name}; '
                                 'change master.heartbeat_producer or heartbeat_multiplier, or set '
                                 'heartbeat_consumer: false for this node')
