"""The SERVOSTAR's EMCY: the manual's error table (report §3.2) and its framing (§2.10, §3.1).

An EMCY is eight bytes: error code (bytes 0-1), error register 0x1001 (byte 2), the error
**category** (byte 3), bytes 4-7 zero. Every EMCY is followed by a second one with code 0x0000
that reports the error state: its register is what is still pending (0: error free). The
categories (byte 3; the table's category where the drive sends 0):

=====  ==========================================  ========================================
cat.   meaning                                     cleared by
=====  ==========================================  ========================================
1      serious fault (Fxx on the front panel)      controlword bit 7 (the drive restarts) or
                                                   COLDSTART
2      following error, response monitoring, ...   controlword bit 11
3      error while a PDO is processed              (warning: the drive goes on)
4      firmware / hardware check                   a restart (bit 7)
5      operating error (not ready, wrong mode)     (warning: the command was not carried out)
=====  ==========================================  ========================================

The power-on message is an EMCY too: 0 bytes, or 8 zero bytes (DRVCNFG), which reads exactly
like "error free"; see :func:`is_bootup`.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Final

from drive_bridge.cia301.emcy import EmcyEvent, Severity, decode_emcy

FAULT_CATEGORIES: Final = frozenset({1, 2, 4})  # the drive stops: a fault until reset
RESTART_CATEGORIES: Final = frozenset({1, 4})  # reset by controlword bit 7: the drive restarts
CATEGORY_NOTES: Final = {
    1: 'category 1: reset by controlword bit 7 (the drive restarts) or COLDSTART',
    2: 'category 2: acknowledged by controlword bit 11',
    3: 'category 3: error while a PDO was processed',
    4: 'category 4: firmware/hardware check (a restart resets it)',
    5: 'category 5: operating error, the command was not carried out',
    6: 'category 6: warning',
}

# code -> (category, front-panel fault, description), the manual's table in its order
ERRORS: Final[Mapping[int, tuple[int, str, str]]] = {
    0x0000: (0, '', 'Error reset or no error (mandatory)'),
    0x1000: (0, '', 'Generic error (mandatory)'),
    0x1080: (5, '', 'No BTB/RTO state (not ready for operation)'),
    0x2330: (2, 'F22', 'Earth fault'),
    0x3100: (1, 'F16', 'No mains BTB (mains not ready / phases missing)'),
    0x3110: (1, 'F02', 'DC-link overvoltage'),
    0x3120: (1, 'F05', 'DC-link undervoltage'),
    0x3130: (1, 'F19', 'One mains phase missing (with PMODE = 2)'),
    0x4110: (1, 'F13', 'Ambient (internal) temperature exceeded'),
    0x4210: (1, 'F01', 'Heat-sink temperature exceeded'),
    0x4310: (1, 'F06', 'Motor temperature exceeded'),
    0x5111: (1, 'F07', '±15 V auxiliary voltage fault'),
    0x5380: (1, 'F17', 'A/D converter fault'),
    0x5400: (1, 'F14', 'Output stage fault'),
    0x5420: (1, 'F18', 'Ballast (brake) chopper fault'),
    0x5441: (1, 'F27', 'Operating error with option AS (safe stop)'),
    0x5530: (1, 'F09', 'Serial EEPROM'),
    0x5581: (1, 'F10', 'Flash EEPROM'),
    0x6010: (4, 'F32', 'Watchdog / software reset'),
    0x6181: (4, '', 'BCC error, table'),
    0x6182: (4, '', 'BCC error, system macro'),
    0x6183: (4, '', 'BCC error, serial EEPROM'),
    0x6184: (4, '', 'FPGA error'),
    0x6185: (4, '', 'Table error'),
    0x6281: (4, 'F32', 'User software BCC (macro)'),
    0x6282: (4, 'F32', 'Faulty user software (macro)'),
    0x6320: (3, '', 'Parameter error'),
    0x7111: (1, 'F11', 'Brake fault'),
    0x7122: (1, 'F25', 'Commutation error'),
    0x7181: (5, '', 'SERVOSTAR could not be enabled'),
    0x7182: (5, '', 'Command only possible in state "disabled"'),
    0x7303: (1, 'F04', 'Feedback unit fault (resolver/encoder)'),
    0x8053: (1, 'F21', 'Handling error (expansion card software)'),
    0x8181: (2, '', 'Response monitoring (node guarding) active'),
    0x8182: (1, 'F23', 'CAN bus-off'),
    0x8281: (5, '', 'State machine is not in "Operation Enable"'),
    0x8282: (5, '', 'Wrong mode setting'),
    0x8331: (1, 'F15', 'I²t torque fault (I²t max)'),
    0x8480: (1, 'F08', 'Overspeed'),
    0x8611: (2, 'F03', 'Following error'),
    0x8681: (5, '', 'Invalid motion-task number'),
    0x8682: (2, 'F28', 'External trajectory error'),
    0xFF01: (4, 'F32', 'Serious exception error'),
    0xFF02: (3, '', 'Error in PDO element'),
    0xFF03: (5, '', 'Operating mode (mode error)'),
    0xFF04: (1, 'F20', 'Slot error (expansion card hardware)'),
    0xFF06: (2, 'F24', 'Warning displayed as error'),
    0xFF07: (2, 'F26', 'Homing error: hardware limit switch reached'),
    0xFF08: (2, 'F29', 'Sercos error (fieldbus not synchronised)'),
    0xFF10: (1, 'F12', 'Motor phase error'),
    0xFF11: (1, '', 'Sercos error (the rest of the row is lost in the manual extract)'),
}
EMCY_TEXTS: Final[Mapping[int, str]] = {code: f'{fault} {text}' if fault else text
                                         for code, (_cat, fault, text) in ERRORS.items()}
BOOTUP_TEXT: Final = 'boot-up (power-on EMCY)'


def is_bootup(data: bytes) -> bool:
    """The power-on message: an EMCY of 0 bytes or of 8 zero bytes."""
    return len(data) == 0 or (len(data) == 8 and not any(data))


def category(event: EmcyEvent) -> int:
    """The error category of an EMCY: byte 3 as sent, else the table's (0: unknown)."""
    sent = event.manufacturer[0] if event.manufacturer else 0
    if sent:
        return sent
    return ERRORS.get(event.code, (0, '', ''))[0]


def is_follow_up(event: EmcyEvent) -> bool:
    """The error-state EMCY (code 0x0000) that follows every EMCY: its register is what is pending."""
    return event.code == 0


def decode(node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent:
    """Text with the fault number and category; severity error for categories 1, 2 and 4,
    warning for 3, 5 and 6; a code 0x0000 frame is the error state (info, a reset)."""
    event = decode_emcy(node_id, node_name, data, timestamp, EMCY_TEXTS)
    if len(data) == 0:
        return event.with_meaning(text=BOOTUP_TEXT + ', 0 bytes', severity=Severity.INFO, reset=True)
    if event.code == 0:
        if event.register:
            text = f'error state: errors still pending (register 0x{event.register:02X})'
        elif not any(data):
            text = 'error free (or the power-on EMCY, 8 zero bytes)'
        else:
            text = 'error free'
        return event.with_meaning(text=text, severity=Severity.INFO, reset=True)
    cat = category(event)
    note = CATEGORY_NOTES.get(cat, f'category {cat}' if cat else '')
    text = f'{event.text} ({note})' if note else event.text
    severity = Severity.ERROR if cat in FAULT_CATEGORIES or cat == 0 else Severity.WARNING
    return event.with_meaning(text=text, severity=severity, reset=False)
