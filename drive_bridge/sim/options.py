"""Simulation options (``simulation.options.<node name>`` in a bus config): declared,
documented and validated in one place, so a typo fails at start with the node and
option named instead of being ignored.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

Value = float | int | bool | str


@dataclass(frozen=True)
class OptionSpec:
    """One option: type (float, int, bool or str), default, bounds or choices, and meaning.
    ``per_axis`` options take a scalar (all axes) or a list with one value per axis."""

    name: str
    kind: type
    default: Value
    doc: str
    minimum: float | None = None
    maximum: float | None = None
    per_axis: bool = False
    choices: tuple[str, ...] = ()  # the values a str option takes


def _spec_table(*specs: OptionSpec) -> dict[str, OptionSpec]:
    return {spec.name: spec for spec in specs}


SLAVE_OPTIONS: dict[str, OptionSpec] = _spec_table(
    OptionSpec('boot_delay', float, 0.0, 's from power-on or NMT reset to the boot-up frame', 0.0, 60.0),
    OptionSpec('serial_number', int, 0, 'identity 0x1018:4', 0, 0xFFFFFFFF),
    OptionSpec('sdo_delay', float, 0.0, 's every SDO response is held back (as set_sdo_delay)', 0.0, 60.0),
    OptionSpec('heartbeat', bool, True,
               'false: a node without heartbeat objects (0x1016/0x1017 absent, SDO aborts 0x06020000, no '
               'heartbeat frames), supervised by node guarding only'),
    OptionSpec('life_guarding_reaction', str, 'emcy',
               "what the node does when the master's guarding RTRs stop for the life time 0x100C x 0x100D: "
               "'emcy' (EMCY 0x8130 life guard error, error register bit 4) or 'none'",
               choices=('emcy', 'none')),
)

# A CiA 402 drive can also stop its axes, as for a lost master heartbeat.
DRIVE_OPTIONS: dict[str, OptionSpec] = {
    **SLAVE_OPTIONS,
    'life_guarding_reaction': replace(
        SLAVE_OPTIONS['life_guarding_reaction'], choices=('emcy', 'none', 'fault'),
        doc="what the drive does when the master's guarding RTRs stop for the life time 0x100C x 0x100D: "
            "'emcy' (EMCY 0x8130 life guard error, error register bit 4), 'none', or 'fault' (the EMCY, then "
            "every axis' fault reaction and Fault, as for a lost master heartbeat)"),
}

AXIS_OPTIONS: dict[str, OptionSpec] = _spec_table(
    OptionSpec('lag_time_constant', float, 0.002,
               's, first-order lag of the actual position behind the demand (0 = none)', 0.0, 10.0, True),
    OptionSpec('inertia', float, 2e-4,
               'per mille of rated torque per count/s^2 (torque = inertia*acc + friction*vel)', 0.0, None, True),
    OptionSpec('friction', float, 1e-3, 'viscous friction, per mille of rated torque per count/s',
               0.0, None, True),
    OptionSpec('home_switch_position', int, 0,
               'counts (power-on coordinates) where homing methods 1..34 find their switch/index', None, None,
               True),
    OptionSpec('homing_timeout', float, 20.0, 's before a homing run ends with the homing error bit',
               0.001, None, True),
    OptionSpec('initial_position', int, 0, 'counts, position actual value at the first power-on',
               -(2 ** 31), 2 ** 31 - 1, True),
)


def _check(node: str, spec: OptionSpec, value: Any) -> Value:
    where = f'simulation option {spec.name!r} of node {node!r}'
    if spec.kind is bool:
        if not isinstance(value, bool):
            raise ValueError(f'{where}: expected true or false, got {value!r}')
        return value
    if spec.kind is str:
        if value not in spec.choices:
            raise ValueError(f'{where}: expected one of {", ".join(map(repr, spec.choices))}, got {value!r}')
        return str(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f'{where}: expected a number, got {value!r}')
    if spec.kind is int:
        if isinstance(value, float) and not value.is_integer():
            raise ValueError(f'{where}: expected an integer, got {value!r}')
        value = int(value)
    else:
        value = float(value)
    if spec.minimum is not None and value < spec.minimum:
        raise ValueError(f'{where}: {value} is below the minimum {spec.minimum}')
    if spec.maximum is not None and value > spec.maximum:
        raise ValueError(f'{where}: {value} is above the maximum {spec.maximum}')
    return value


def resolve_options(specs: Mapping[str, OptionSpec], given: Mapping[str, Any] | None, node: str,
                    axes: int = 1) -> dict[str, Any]:
    """Validated options with defaults filled in; per-axis options become tuples of ``axes`` values.

    Raises ValueError naming the node and the option for unknown names, wrong types,
    out-of-range values and per-axis lists of the wrong length.
    """
    given = dict(given or {})
    unknown = sorted(set(given) - set(specs))
    if unknown:
        raise ValueError(f'unknown simulation option {unknown[0]!r} for node {node!r}; '
                         f'known: {", ".join(sorted(specs))}')
    resolved: dict[str, Any] = {}
    for name, spec in specs.items():
        value = given.get(name, spec.default)
        if spec.per_axis:
            if isinstance(value, Sequence) and not isinstance(value, str):
                if len(value) != axes:
                    raise ValueError(f'simulation option {name!r} of node {node!r}: '
                                     f'{len(value)} values for {axes} axes')
                resolved[name] = tuple(_check(node, spec, v) for v in value)
            else:
                resolved[name] = (_check(node, spec, value),) * axes
        else:
            resolved[name] = _check(node, spec, value)
    return resolved


def describe(specs: Mapping[str, OptionSpec]) -> str:
    """One line per option, for docs and error messages."""
    return '\n'.join(f'{s.name} (default {s.default!r}): {s.doc}' for s in specs.values())
