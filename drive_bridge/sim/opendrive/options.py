"""The simulated OPEN drive's options (``simulation.nodes.<node>`` in a bus config): the drive's
constants the CAN appendix does not give, its firmware's compile-time choices, and the readings
where the appendix leaves room (package docstring)."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from drive_bridge.sim.opendrive.quantities import SPEED_DEFAULT, TORQUE_DEFAULT, full_scale
from drive_bridge.sim.options import SLAVE_OPTIONS, OptionSpec

GUARDING_FIRMWARE = ('none', 'stop', 'alarm')  # life guarding reactions a firmware may be compiled with

OPENDRIVE_OPTIONS: dict[str, OptionSpec] = {
    **SLAVE_OPTIONS,
    'heartbeat': replace(SLAVE_OPTIONS['heartbeat'], default=False,
                         doc='the OPEN drive has no heartbeat objects (0x1016/0x1017 are not in its EDS): '
                             'supervised by node guarding'),
    'life_guarding_reaction': replace(
        SLAVE_OPTIONS['life_guarding_reaction'], default='none', choices=GUARDING_FIRMWARE,
        doc="the firmware's reaction when the master's guarding RTRs stop for the life time 0x100C x 0x100D "
            "(at most 32767 / pwm_frequency s; the appendix: chosen when the firmware is compiled, by default "
            "none): 'none' (the default firmware: the drive keeps running on its last RUN and references), "
            "'stop' (RUN forced low while the RTRs stay away, back with them; no EMCY) or 'alarm' (alarm "
            "A<guarding_alarm> trips: latched, the drive stops, EMCY if P163 enables it; an alarm reset clears "
            "it once the RTRs are back)"),
    'guarding_alarm': OptionSpec('guarding_alarm', int, 15,
                                 "the alarm An of life_guarding_reaction 'alarm' (the appendix names no alarm for it)",
                                 0, 15),
    'c52': OptionSpec('c52', int, 1, 'factory value of connection C52 (1: references 0x201A-0x201D from CAN)',
                      0, 1),
    'speed_reference': OptionSpec('speed_reference', str, '0x201A',
                                  "the speed reference the drive is set up to use: '0x201A' (f_fieldbus, "
                                  "16384 = n_MAX) or '0x201D' (theta_fieldbus, electrical pulses per PWM period)",
                                  choices=('0x201A', '0x201D')),
    'control_mode': OptionSpec('control_mode', str, 'speed',
                               "'speed' (0x201A / 0x201D) or 'torque' (0x201C) control", choices=('speed', 'torque')),
    'actual_speed_element': OptionSpec('actual_speed_element', int, 0,
                                       'element k of Tab_osc 0x2012 / Tab_int 0x200F carrying the actual speed '
                                       '(n_MAX = 100 %)', 0, 63),
    'actual_speed_representation': OptionSpec('actual_speed_representation', int, SPEED_DEFAULT,
                                               'its representation word in 0x2004 / 0x2003: 0x0002 (% of 4095), '
                                               '0x0003 (% of 32767) or 0x00n1 (direct / 2^n); default 0x00E1 '
                                               '(16384 = n_MAX, as 0x201A)', 0, 0xFFFF),
    'actual_torque_element': OptionSpec('actual_torque_element', int, 1,
                                        'element carrying the actual torque (T_nom = 100 %)', 0, 63),
    'actual_torque_representation': OptionSpec('actual_torque_representation', int, TORQUE_DEFAULT,
                                                'its representation word; default 0x0002 (% of 4095: 4095 = '
                                                'T_nom, as 0x201C)', 0, 0xFFFF),
    'position_element': OptionSpec('position_element', int, -1,
                                   'element carrying the mechanical angle in 65536 counts per revolution '
                                   '(INT16, wraps every revolution; format word 0x0001); -1 or None: none',
                                   -1, 63),
    'array_offset': OptionSpec('array_offset', int, 1,
                               'array element k sits at sub-index k + array_offset (0: element 0 unreachable)',
                               0, 1),
    'n_max_rpm': OptionSpec('n_max_rpm', float, 3000.0, 'n_MAX, the set maximum speed (16384 in 0x201A)',
                            1.0, 1e6),
    'rated_torque': OptionSpec('rated_torque', float, 10.0, 'T_nom in N m (4095 in 0x201B / 0x201C)', 1e-6, 1e6),
    'pole_pairs': OptionSpec('pole_pairs', int, 4, 'motor pole pairs (0x201D)', 1, 100),
    'pwm_frequency': OptionSpec('pwm_frequency', float, 8000.0,
                                'f_pwm in Hz (0x201D; life time limit 32767 / f_pwm s)', 1.0, 1e6),
    'alarm_reset_function': OptionSpec('alarm_reset_function', int, 5,
                                       'standard logic input function that resets the alarms (rising edge)',
                                       1, 31),
    'terminal_run': OptionSpec('terminal_run', bool, True,
                               'terminal input 1 (RUN, C1 = 0) is high at the start of the simulation'),
    'speed_time_constant': OptionSpec('speed_time_constant', float, 0.05,
                                      's, first-order lag of the speed behind its reference', 0.0, 100.0),
    'coast_time_constant': OptionSpec('coast_time_constant', float, 1.0,
                                      's, decay of the speed while the inverter is off', 0.0, 1000.0),
    'inertia': OptionSpec('inertia', float, 0.002, 'kg m^2 at the motor shaft', 1e-9, None),
    'friction': OptionSpec('friction', float, 0.001, 'viscous friction, N m s / rad', 0.0, None),
    'reserved_key': OptionSpec('reserved_key', int, 1, 'value of P60 that unlocks the Reserved parameters',
                               0, 65535),
    'tde_key': OptionSpec('tde_key', int, 1, 'value of P99 that unlocks the TDE parameters', 0, 65535),
}


def check_options(name: str, options: Mapping[str, Any]) -> None:
    """What the option specs cannot check alone: distinct actual-value elements, and
    representation words the appendix's reading can decode."""
    elements = [options['actual_speed_element'], options['actual_torque_element']]
    if options['position_element'] >= 0:
        elements.append(options['position_element'])
    if len(set(elements)) != len(elements):
        raise ValueError(f'simulation options of node {name!r}: actual_speed_element, '
                         f'actual_torque_element and position_element must differ')
    for option in ('actual_speed_representation', 'actual_torque_representation'):
        try:
            full_scale(options[option])
        except ValueError as error:
            raise ValueError(f'simulation option {option!r} of node {name!r}: {error}') from None
