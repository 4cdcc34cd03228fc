"""The bus node's ROS parameters: declared with descriptions, validated together.

Two classes (docs/interfaces.md, "Parameters"): start-time parameters act only while the node starts
(lifecycle node: at configure) and are refused once it runs (configured), with the reason;
run-time parameters (:data:`RUN_TIME`) are validated with the others and applied at once.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from drive_bridge.ros.errors import NodeParameterRefused

COMMAND_INTERFACES = ('position', 'velocity', 'effort')
RELIABILITIES = ('reliable', 'best_effort')


@dataclass(frozen=True)
class BridgeParameters:
    config: str = ''
    config_yaml: str = ''
    simulate: bool = False
    sync_period: float = 0.0
    publish_rate: float = 0.0
    joint_states_topic: str = '/joint_states'
    state_rate: float = 10.0
    diagnostics_period: float = 1.0
    publish_frames: bool = True
    qos_depth: int = 10
    qos_reliability: str = 'reliable'
    command_interface: str = 'position'
    command_joints: tuple[str, ...] = ()
    joint_commands_topic: str = '~/joint_commands'
    auto_enable: bool = False
    pvt_segment: float = 0.01
    pvt_lookahead: float = 0.05
    node_nice: int = 10


DESCRIPTIONS = {
    'config': 'path of the bus configuration YAML (empty: use config_yaml)',
    'config_yaml': 'the bus configuration as YAML text, instead of a file',
    'simulate': 'start simulated drives for every node (virtual bus only)',
    'sync_period': 'SYNC period in seconds; 0 = as in the bus configuration',
    'publish_rate': 'joint state rate in Hz; 0 = every SYNC cycle',
    'joint_states_topic': 'topic of the stamped sensor_msgs/JointState of all joints',
    'state_rate': 'rate in Hz of ~/axis_states (also sent on every state change)',
    'diagnostics_period': 'seconds between /diagnostics messages',
    'publish_frames': 'publish every CAN frame on ~/can_frames',
    'qos_depth': 'history depth of the state topics',
    'qos_reliability': 'reliable or best_effort, for the state topics',
    'command_interface': 'what ~/commands carries: position, velocity or effort',
    'command_joints': 'joint order of ~/commands (empty: all joints in configuration order)',
    'joint_commands_topic': 'sensor_msgs/JointState command topic (topic_based_ros2_control)',
    'auto_enable': 'enable every axis once its node is operational',
    'pvt_segment': 'seconds between PVT points (a whole number of ms)',
    'pvt_lookahead': 'seconds of PVT points kept ahead in the drive buffer',
    'node_nice': ('niceness the node process adds to itself once its bus process runs (0..19; bridge and '
                  'bridge_managed only): the SYNC cycle gets the CPU before what clients make the node do'),
}


# applied while the node runs; every other parameter acts only at start
RUN_TIME = frozenset({'publish_rate', 'state_rate', 'diagnostics_period', 'pvt_segment', 'pvt_lookahead'})
START_TIME = frozenset(f.name for f in fields(BridgeParameters)) - RUN_TIME
_DEFAULTS = {f.name: f.default for f in fields(BridgeParameters)}
# Every number a parameter takes: finite, in [low, high]; ``zero``: 0 is also allowed (its own
# meaning, in DESCRIPTIONS). Timers faster than these would starve the services and
# subscriptions; slower ones are silence, not a rate.
RANGES: dict[str, tuple[float, float, bool]] = {
    'sync_period': (0.0001, 1.0, True),  # s; 0 = as in the bus configuration
    'publish_rate': (0.1, 1000.0, True),  # Hz; 0 = every SYNC cycle
    'state_rate': (0.1, 100.0, True),  # Hz; 0 = on change only
    'diagnostics_period': (0.05, 3600.0, False),  # s
    'pvt_segment': (0.001, 1.0, False),  # s, a whole number of ms
    'pvt_lookahead': (0.001, 5.0, False),  # s, >= pvt_segment
    'qos_depth': (1, 10000, False),
    'node_nice': (0, 19, True),
}
MAX_STATE_RATE = RANGES['state_rate'][1]  # Hz
MIN_DIAGNOSTICS_PERIOD = RANGES['diagnostics_period'][0]  # s


def _typed(name: str, value: Any) -> Any:
    """A ROS parameter value as the BridgeParameters field takes it."""
    default = _DEFAULTS[name]
    if isinstance(default, tuple):
        return tuple(value or ())
    if isinstance(default, float) and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


def declare(node: Node) -> BridgeParameters:
    """Declare every parameter and return them validated (NodeParameterRefused lists all problems)."""
    problems = []
    for f in fields(BridgeParameters):
        default = f.default
        declared_default = list(default) if isinstance(default, tuple) else default
        when = 'run time: applied at once' if f.name in RUN_TIME else 'start time: read-only once the node runs'
        descriptor = ParameterDescriptor(description=DESCRIPTIONS[f.name], additional_constraints=when)
        if isinstance(default, tuple):
            descriptor.type = ParameterType.PARAMETER_STRING_ARRAY
        # an empty list default would make rclpy infer a byte array: declare string arrays by type
        declared = Parameter.Type.STRING_ARRAY if isinstance(default, tuple) and not default else declared_default
        try:
            node.declare_parameter(f.name, declared, descriptor)
        except ParameterException as exc:
            problems.append(f'parameter {f.name}: {exc}')
    if problems:
        raise NodeParameterRefused('; '.join(problems))
    return read(node)


def read(node: Node) -> BridgeParameters:
    """The node's present parameter values, validated (NodeParameterRefused lists all problems)."""
    params = BridgeParameters(**{f.name: _typed(f.name, node.get_parameter_or(f.name).value)
                                 for f in fields(BridgeParameters)})
    problems = validate(params)
    if problems:
        raise NodeParameterRefused('; '.join(problems))
    return params


def watch(node: Node, running: Callable[[], BridgeParameters | None],
          apply: Callable[[BridgeParameters], None]) -> None:
    """Guard the node's parameters at run time. ``running()``: the parameters in force, None
    while the node is not running (lifecycle: unconfigured; then anything may be set and is
    checked at configure). While it runs, a start-time parameter is refused with the reason,
    and run-time ones are validated with the rest, then handed to ``apply``."""
    def on_set(parameters: Sequence[Parameter]) -> SetParametersResult:
        current = running()
        if current is None:
            return SetParametersResult(successful=True)
        fixed = [p.name for p in parameters if p.name in START_TIME]
        if fixed:
            return SetParametersResult(successful=False, reason=(
                f'{", ".join(fixed)}: {"acts" if len(fixed) == 1 else "act"} only at start, read-only while the node '
                'runs; restart the node (lifecycle node: cleanup, set, configure) to change '
                f'{"it" if len(fixed) == 1 else "them"}. Changeable at run time: {", ".join(sorted(RUN_TIME))}'))
        problems = validate(_updated(current, parameters))
        if problems:
            return SetParametersResult(successful=False, reason='; '.join(problems))
        return SetParametersResult(successful=True)

    def on_applied(parameters: Sequence[Parameter]) -> None:
        current = running()
        if current is not None and any(p.name in RUN_TIME for p in parameters):
            apply(_updated(current, parameters))

    node.add_on_set_parameters_callback(on_set)
    node.add_post_set_parameters_callback(on_applied)


def _updated(current: BridgeParameters, parameters: Sequence[Parameter]) -> BridgeParameters:
    known = [p for p in parameters if p.name in _DEFAULTS]
    return dataclasses.replace(current, **{p.name: _typed(p.name, p.value) for p in known})


def _range_text(name: str) -> str:
    low, high, zero = RANGES[name]
    return f'{"0 or " if zero else ""}a finite number in {low:g}..{high:g}'


def _in_range(name: str, value: object) -> bool:
    low, high, zero = RANGES[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return False
    return low <= value <= high or (zero and value == 0)


def validate(params: BridgeParameters) -> list[str]:
    problems = []
    if params.config and params.config_yaml:
        problems.append('parameters config and config_yaml are exclusive: give one')
    bad = {name for name in RANGES if not _in_range(name, getattr(params, name))}
    problems += [f'parameter {name} must be {_range_text(name)}, got {getattr(params, name)!r}' for name in sorted(bad)]
    if 'pvt_segment' not in bad and abs(params.pvt_segment * 1000 - round(params.pvt_segment * 1000)) > 1e-6:
        problems.append(f'parameter pvt_segment must be a whole number of ms, got {params.pvt_segment}')
    if not bad & {'pvt_segment', 'pvt_lookahead'} and params.pvt_lookahead < params.pvt_segment:
        problems.append(f'parameter pvt_lookahead must be >= pvt_segment, got {params.pvt_lookahead}')
    if params.qos_reliability not in RELIABILITIES:
        problems.append(f'parameter qos_reliability must be one of {", ".join(RELIABILITIES)}, '
                        f'got {params.qos_reliability!r}')
    if params.command_interface not in COMMAND_INTERFACES:
        problems.append(f'parameter command_interface must be one of {", ".join(COMMAND_INTERFACES)}, '
                        f'got {params.command_interface!r}')
    return problems
