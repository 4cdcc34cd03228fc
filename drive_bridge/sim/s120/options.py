"""The simulated S120's options (``simulation.nodes.<node>`` in a bus config): the Control Unit's
settings the manual leaves to commissioning, its readings where it leaves room, and per-axis
motor data (package docstring)."""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

from drive_bridge.cia402 import objects as obj
from drive_bridge.sim.options import AXIS_OPTIONS, SLAVE_OPTIONS, OptionSpec
from drive_bridge.sim.s120.axis import S120Axis
from drive_bridge.sim.s120.objects import CU, MAX_DRIVE_OBJECTS, P8684_STATES

_AXIS = {name: replace(spec) for name, spec in AXIS_OPTIONS.items()}
_AXIS['inertia'] = replace(AXIS_OPTIONS['inertia'], default=1e-7,
                           doc='per mille of r0333 per increment/s^2 (for 2048 x 2^11 increments per '
                               'revolution: rated torque reaches 3000 rpm in about 20 ms)')
_AXIS['friction'] = replace(AXIS_OPTIONS['friction'], default=5e-8,
                            doc='viscous friction, per mille of r0333 per increment/s')


def _axis_option(name: str, kind: type, default: Any, doc: str, low: float | None = None,
                 high: float | None = None) -> OptionSpec:
    return OptionSpec(name, kind, default, doc, low, high, per_axis=True)


S120_OPTIONS: dict[str, OptionSpec] = {
    **{name: spec for name, spec in SLAVE_OPTIONS.items() if name != 'life_guarding_reaction'},
    'drive_objects': OptionSpec('drive_objects', int, 0,
                                'number of motor drive objects (axis slots) of the Control Unit; 0: every '
                                'axis the object dictionary has (0x6040 + 0x800 k)', 0, MAX_DRIVE_OBJECTS),
    'p8684': OptionSpec('p8684', int, 127, 'NMT state after start-up: 127 pre-operational (factory), '
                                           '5 operational, 4 stopped', 4, 127),
    'p8848': OptionSpec('p8848', float, 4.0, 'ms, CAN (IF2 PZD) sampling time: RPDOs must come at most every '
                                             '2 x p8848 (A08751)', 1.0, 500.0),
    'mapping_sub0_read_only': OptionSpec('mapping_sub0_read_only', bool, False,
                                         "true: PDO mapping sub 0 is read-only (the manual's Tab. 2-3/2-4); "
                                         "false: read-write as in the real EDS (the CiA 301 procedure works "
                                         "too). Either way the entries of an invalid PDO may be written "
                                         "whatever sub 0 holds (the manual's online procedure) and sub 0 "
                                         "follows the leading non-zero entries"),
    'predefined_mapping': OptionSpec('predefined_mapping', bool, True,
                                     "PDO 1..4 of every drive object whose mapping the EDS leaves empty get the "
                                     "Predefined Connection Set's mapping (+0x800 per slot)"),
    'address_switch': OptionSpec('address_switch', int, 0,
                                 "the Control Unit's address switch (\"DP Address\", two hex digits) at power-on: "
                                 "1..127 is the node id and shows in p8620; 0 (or beyond 127): the node id is "
                                 "p8620 (the node config's id until a saved p8620 differs); read at POWER ON "
                                 "only (set_address_switch)", 0, 255),
    'node_id_at_reboot': OptionSpec('node_id_at_reboot', bool, False,
                                    'the reboot of the Control Unit after p0009 = 0 also reads the node id '
                                    '(switch, saved p8620), as a power-on does; false: only POWER ON (the '
                                    "manual's words, §4.2.4.2)"),
    'reboot_delay': OptionSpec('reboot_delay', float, 0.05, 's from p0009 = 0 to the reboot of the Control Unit',
                               0.0, 60.0),
    **_AXIS,
    'do_numbers': _axis_option('do_numbers', int, 0, 'drive-object number of the axis slot (p8743); 0: 2 + slot',
                               0, 62),
    'encoder': _axis_option('encoder', bool, True, 'true: velocities in increments/s; false: in rpm, 0x6063 = 0'),
    'encoder_pulses': _axis_option('encoder_pulses', int, 2048, 'p0408, encoder pulses per revolution', 1, 65535),
    'fine_resolution': _axis_option('fine_resolution', int, 11, 'p0418, fine resolution in bits', 2, 18),
    'rated_torque': _axis_option('rated_torque', float, 10.0, 'r0333, rated motor torque in N m', 1e-3, 1e5),
    'rated_speed': _axis_option('rated_speed', float, 3000.0, 'p0311, rated motor speed in rpm', 1.0, 210000.0),
    'max_speed': _axis_option('max_speed', float, 3000.0, 'p1082, maximum speed in rpm', 1.0, 210000.0),
    'ramp_up_time': _axis_option('ramp_up_time', float, 10.0, 'p1120, s from 0 to p1082 (SINAMICS factory '
                                                              'value)', 0.0, 999999.0),
    'ramp_down_time': _axis_option('ramp_down_time', float, 10.0, 'p1121, s from p1082 to 0', 0.0, 999999.0),
    'off3_ramp_down_time': _axis_option('off3_ramp_down_time', float, 0.0,
                                        'p1135, OFF3 (quick stop) s from p1082 to 0 (0: at the torque limit)',
                                        0.0, 5400.0),
    'torque_limit': _axis_option('torque_limit', float, 0.0, 'p1520 in N m; 0: 2 x r0333', 0.0, 1e6),
    'p8641': _axis_option('p8641', int, 0, 'reaction to a CAN communication error: 0 none (factory), 1 OFF1, '
                                           '2 OFF2, 3 OFF3 (= 0x6007)', 0, 3),
    'mode': _axis_option('mode', int, 3, 'mode at power-on (p1300): 2 vl, 3 pv, 4 pt', 2, 4),
}


def drive_object_count(name: str, requested: Any, available: int) -> int:
    """The motor drive objects of node ``name`` (``drive_objects``: 0 for every one of the
    ``available`` axis slots of its object dictionary)."""
    if isinstance(requested, bool) or not isinstance(requested, int) or requested <= 0:
        return available  # (a wrong type or range is reported by the option check)
    if requested > available:
        raise ValueError(f'simulation option drive_objects of node {name!r}: {requested} drive objects, '
                         f'but the object dictionary has the objects of {available} axis slot(s) '
                         f'(0x6040 + 0x800 k)')
    return requested


def check_options(name: str, options: Mapping[str, Any], axes: Sequence[S120Axis]) -> None:
    """What the option specs cannot check alone: distinct drive object numbers, p8684, boot modes."""
    where = f'simulation options of node {name!r}'
    numbers = [a.do_number for a in axes]
    if len(set(numbers)) != len(numbers) or CU in numbers:
        raise ValueError(f'{where}: do_numbers {numbers} must differ from each other and from the Control '
                         f'Unit (1)')
    if options['p8684'] not in P8684_STATES:
        raise ValueError(f'{where}: p8684 must be 4 (stopped), 5 (operational) or 127 (pre-operational), '
                         f'got {options["p8684"]}')
    for axis in axes:
        if not axis.supports(axis.boot_mode):
            raise ValueError(f'{where}: mode {axis.boot_mode} of slot {axis.slot}: the object dictionary '
                             f'lacks its objects (vl needs 0x{obj.for_axis(0x6042, axis.slot):04X})')
