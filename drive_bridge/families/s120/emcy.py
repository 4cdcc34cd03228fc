"""SINAMICS EMCY: the fault or alarm number and the drive object that raised it
(shared/drives/sinamics-s120-cbc10.md §2.7, §6; manual §6.2-6.4).

Frame (Tab. 6-3): bytes 0-1 the CANopen error code, byte 2 the error register 0x1001, bytes
3-4 the SINAMICS fault/alarm number (little-endian), byte 5 the number of the drive object
(DO) that raised it, bytes 6-7 reserved. The error codes SINAMICS sends (Tab. 6-4):

======  ===============================================================================
0x0000  every fault acknowledged / every alarm gone (a reset; the whole CU)
0x1000  any SINAMICS fault outside the cases below (the cause is the number in bytes 3-4)
0x1001  the other CANopen alarms F08700..F08799
0x8110  A08751 telegram loss (also a receive cycle < 2 x p8848)
0x8120  A08752 error passive
0x8130  F08700 value 2: life guarding / CAN communication error (reaction p8641)
======  ===============================================================================

The DO number goes to the joint through p8743 (slot -> DO number), read at boot: an EMCY of DO 3
on a node with p8743 = [4, 3] is the slot-1 joint's, whatever the order of the config's axes.
A DO the node has no axis for (the Control Unit, DO 1, or an infeed) gives ``slot = None``: the
event concerns every joint of the node.

Alarms outside the CAN range send no EMCY at all (§6.2): they show only as the statusword's
warning bit (``AxisSnapshot.warning``).

Texts: the CAN-range numbers the manual names (F08700, A08751, A08752, A08758) are from the
manual; the other CBC numbers (A08701, F08702, A08753..A08757, A08759, A08760) and the drive
faults below are the SINAMICS list manual's, marked [B] in the facts file: to be checked there.
"""
from __future__ import annotations

from collections.abc import Mapping

from drive_bridge.cia301.emcy import EmcyEvent, Severity, decode_emcy

CODE_RESET = 0x0000
CODE_FAULT = 0x1000
CODE_CAN_ALARM = 0x1001
CODE_TELEGRAM_LOSS = 0x8110
CODE_ERROR_PASSIVE = 0x8120
CODE_LIFE_GUARD = 0x8130

EMCY_CODE_TEXTS: Mapping[int, str] = {
    CODE_RESET: 'all faults acknowledged, all alarms gone',
    CODE_FAULT: 'SINAMICS fault',
    CODE_CAN_ALARM: 'SINAMICS CAN alarm (F08700..F08799)',
    CODE_TELEGRAM_LOSS: 'CAN overflow, message lost (A08751)',
    CODE_ERROR_PASSIVE: 'CAN error passive (A08752)',
    CODE_LIFE_GUARD: 'CAN life guard error (F08700 value 2)',
}

# number -> (F: fault, A: alarm; text)
MESSAGES: Mapping[int, tuple[str, str]] = {
    # the CAN range (CBC10)
    8700: ('F', 'CBC: communication error (value 2 in r0949: life guarding timeout or too many lost telegrams; '
                'the drive reacts as p8641 says)'),
    8701: ('A', 'CBC: NMT state change (the node left OPERATIONAL)'),
    8702: ('F', 'CBC: RPDO timeout'),
    8751: ('A', 'CBC: telegram loss (a receive cycle shorter than 2 x p8848, or lost RPDOs)'),
    8752: ('A', 'CBC: error counter for error passive exceeded'),
    8753: ('A', 'CBC: message buffer overflow'),
    8754: ('A', 'CBC: incorrect communication mode (PDO parameters changed while OPERATIONAL)'),
    8755: ('A', 'CBC: object cannot be mapped'),
    8756: ('A', 'CBC: number of mapped bytes exceeded'),
    8757: ('A', 'CBC: set the COB-ID invalid before changing the PDO online'),
    8758: ('A', 'CBC: maximum number of valid PDOs exceeded (at most 25 valid RPDOs per Control Unit)'),
    8759: ('A', 'CBC: PDO COB-ID already in use'),
    8760: ('A', 'CBC: maximum size of the PZD interface exceeded'),
    # drive faults
    1000: ('F', 'internal software error'),
    1001: ('F', 'floating point exception'),
    7011: ('F', 'motor overtemperature'),
    7410: ('F', 'current controller output limited'),
    7801: ('F', 'motor overcurrent'),
    7860: ('F', 'external fault 1'),
    7900: ('F', 'motor blocked'),
    7901: ('F', 'motor overspeed'),
    7910: ('A', 'motor overtemperature'),
    30001: ('F', 'power unit: overcurrent'),
    30002: ('F', 'DC link voltage, overvoltage'),
    30003: ('F', 'DC link voltage, undervoltage'),
    30005: ('F', 'power unit: overload I2t'),
    30011: ('F', 'line phase failure in main circuit'),
    30021: ('F', 'power unit: ground fault'),
    31100: ('F', 'encoder 1: zero mark distance error'),
    31110: ('F', 'encoder 1: serial communications faulted'),
}


def message_name(number: int, code: int) -> str:
    """'F07900' / 'A08751': the number with the letter its table row or EMCY code gives."""
    kind = MESSAGES.get(number, ('A' if code in (CODE_TELEGRAM_LOSS, CODE_ERROR_PASSIVE) else 'F', ''))[0]
    return f'{kind}{number:05d}'


def message_text(number: int, code: int) -> str:
    """'F07900 motor blocked'; unknown numbers: 'F12345 (see the SINAMICS list manual)'."""
    text = MESSAGES.get(number, ('', ''))[1] or 'not in the family table (see the SINAMICS list manual)'
    return f'{message_name(number, code)} {text}'


def _severity(number: int, code: int) -> Severity:
    if code in (CODE_TELEGRAM_LOSS, CODE_ERROR_PASSIVE):
        return Severity.WARNING
    if code in (CODE_LIFE_GUARD, CODE_FAULT):
        return Severity.ERROR
    kind = MESSAGES.get(number, ('F' if code == CODE_FAULT else 'A', ''))[0]
    return Severity.WARNING if kind == 'A' else Severity.ERROR


def decode(node_id: int, node_name: str, data: bytes, timestamp: float,
           slot_of_do: Mapping[int, int]) -> EmcyEvent:
    """The EMCY with the SINAMICS message as text, the joint's slot from its DO number
    (``slot_of_do``: p8743 inverted), severity from fault / alarm, reset for 0x0000."""
    event = decode_emcy(node_id, node_name, data, timestamp, EMCY_CODE_TEXTS)
    manufacturer = bytes(event.manufacturer).ljust(3, b'\0')
    number = manufacturer[0] | manufacturer[1] << 8
    drive_object = manufacturer[2]
    slot = slot_of_do.get(drive_object)
    if event.code == CODE_RESET:
        return event.with_meaning(text=EMCY_CODE_TEXTS[CODE_RESET], slot=None, severity=Severity.INFO, reset=True)
    if event.code not in EMCY_CODE_TEXTS and not number:
        return event.with_meaning(slot=slot, reset=False)  # not a SINAMICS EMCY layout: CiA 301's reading
    if slot is not None:
        place = f'DO {drive_object}, axis slot {slot}'
    else:
        place = f'DO {drive_object}' + (', no axis of this node' if slot_of_do else ', p8743 not read yet')
    text = f'{message_text(number, event.code)} ({place}; EMCY 0x{event.code:04X} {event.text})'
    return event.with_meaning(text=text, slot=slot, severity=_severity(number, event.code), reset=False)
