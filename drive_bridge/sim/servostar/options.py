"""The simulated SERVOSTAR's options (``simulation.nodes.<node>`` in a bus config): the readings
of the manual where it leaves room, the power-on values the manual gives no default for (package
docstring)."""
from __future__ import annotations

from dataclasses import replace

from drive_bridge.sim.options import AXIS_OPTIONS, SLAVE_OPTIONS, OptionSpec
from drive_bridge.sim.servostar.emcy import REGISTER_READINGS

_choice = OptionSpec  # short alias for the table below

SERVOSTAR_OPTIONS: dict[str, OptionSpec] = {
    **SLAVE_OPTIONS,
    'heartbeat': replace(SLAVE_OPTIONS['heartbeat'], default=False,
                         doc='the SERVOSTAR has no heartbeat objects (0x1016/0x1017): node guarding only'),
    'life_guarding_reaction': replace(
        SLAVE_OPTIONS['life_guarding_reaction'], default='n04', choices=('n04',),
        doc='fixed: warning n04 (0x1002 bit 3), EMCY 0x8181 category 2, quick-stop ramp, motion blocked until '
            'controlword bit 11; only while the output stage is enabled'),
    **AXIS_OPTIONS,
    'inertia': replace(AXIS_OPTIONS['inertia'], default=2e-7),  # the model counts 2^20 per revolution
    'friction': replace(AXIS_OPTIONS['friction'], default=1e-6),
    'drvcnfg': _choice('drvcnfg', int, 0, 'DRVCNFG (0x3672:01) as saved in the EEPROM (the manual gives no default)',
                       0, 0x7FFFFFFF),
    'bootup_length_bit': _choice('bootup_length_bit', int, 0,
                                 'the DRVCNFG bit that makes the power-on EMCY 0 bytes long (else 8 zero bytes): '
                                 '0 (manual §2.6) or 2 (§6.1.1)', 0, 2),
    'hardware_enable': _choice('hardware_enable', bool, True, 'the hardware enable input at power-on'),
    'pdo33_half_select': _choice('pdo33_half_select', str, 'offset',
                                 "how 0x2721 picks this drive's half of RPDO 33: 'offset' (0 = bytes 0-3, 4 = "
                                 "bytes 4-7, as the worked example writes), 'index' (0 / 1, as the object text "
                                 "says) or 'nonzero' (0 = low, 1..4 = high)", choices=('offset', 'index', 'nonzero')),
    'trajectory_setpoints': _choice('trajectory_setpoints', str, 'absolute',
                                    "mode 0xFA: each 0x2022:04 value is the 'absolute' position setpoint "
                                    "(2^PRBASE per revolution) or a 'relative' step", choices=('absolute', 'relative')),
    'trajectory_timing': _choice('trajectory_timing', str, 'dip',
                                 "mode 0xFA, SYNC interval != PTBASE: 'dip' (only the speed profile dips, as "
                                 "the manual says) or 'error' (three mismatched intervals in a row raise EMCY "
                                 "0x8682 category 2 and the emergency ramp)", choices=('dip', 'error')),
    'trajectory_step_check': _choice('trajectory_step_check', str, 'following_error',
                                     "mode 0xFA, a step beyond VLIM x PTBASE: 'following_error' (the demand is "
                                     "limited to VLIM, the following error grows to PEMAX) or 'error' (EMCY "
                                     "0x8611 at once)", choices=('following_error', 'error')),
    'digital_setpoint': _choice('digital_setpoint', str, 'immediate',
                                "modes 0xFE/0xFD: 0x2060 acts 'immediate'ly (RPDO 22/32 'executed "
                                "immediately') or at the next controlword write with Enable Operation "
                                "('enable', the object text)", choices=('immediate', 'enable')),
    'fault_bit3': _choice('fault_bit3', bool, False,
                          'statusword bit 3 set while an error (category 1 or 2) is pending (the manual names '
                          'bit 3 "Fault" but has no Fault state)'),
    'actual_position_resolution': _choice('actual_position_resolution', str, 'fixed',
                                          "0x2070:03 in 2^20 per revolution ('fixed') or 2^PRBASE ('prbase', "
                                          "the OD table's 'depends on PRBASE')", choices=('fixed', 'prbase')),
    'emcy_error_register': _choice('emcy_error_register', str, 'class',
                                   "the error register bits of an error: 'class' (only its code's class bit, "
                                   "bit 7 for a code of no class: 4310h gives 08h as the manual's EMCY examples "
                                   "print) or 'cia301' (generic bit 0 with the class bit: 09h)",
                                   choices=REGISTER_READINGS),
    'emcy_follow_up_category': _choice('emcy_follow_up_category', bool, False,
                                       'byte 3 of the follow-up EMCY (code 0000h) repeats the category (the '
                                       'sentence of §3.4.4.2); false: 00h, as the printed follow-up of §6.2.1.1'),
    'nmt_undocumented': _choice('nmt_undocumented', str, 'cia',
                                "NMT enter pre-operational (0x80) and reset communication (0x82), which the "
                                "manual does not mention: 'cia' (obeyed) or 'ignore'", choices=('cia', 'ignore')),
}
