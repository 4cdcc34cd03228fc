"""The OPEN drive's alarms: the 16-bit alarm word (0x2018, EMCY bytes 3-4, bit n = alarm An)
and its EMCY (shared/drives/opendrive.md §2.6, §3.8).

The EMCY error code is only 0x10xx (generic error: an enabled alarm tripped) or 0x00xx
(alarms reset; bytes 3-4 then hold the alarms still active). The appendix names no alarm;
it says which error register bit each sets: A3 current, A4-A6 temperature, A10, A11, A13
voltage. Those are the names used here ("alarm A3 overcurrent"); any other alarm is "alarm An".
"""
from __future__ import annotations

from drive_bridge.cia301.emcy import EmcyEvent, Severity, decode_emcy

ALARM_NAMES: dict[int, str] = {
    3: 'overcurrent',
    4: 'temperature', 5: 'temperature', 6: 'temperature',
    10: 'voltage', 11: 'voltage', 13: 'voltage',
}
EMCY_TEXTS = {0x0000: 'alarms reset', 0x1000: 'alarm'}


def alarm_name(number: int) -> str:
    """'A3 overcurrent', 'A7' (the appendix names only some)."""
    name = ALARM_NAMES.get(number)
    return f'A{number} {name}' if name else f'A{number}'


def alarm_numbers(word: int) -> list[int]:
    return [n for n in range(16) if word >> n & 1]


def alarm_text(word: int) -> str:
    """'alarm A3 overcurrent', 'alarm A7', 'alarms A3 overcurrent, A7' ('' for 0)."""
    numbers = alarm_numbers(word)
    if not numbers:
        return ''
    return ('alarm ' if len(numbers) == 1 else 'alarms ') + ', '.join(alarm_name(n) for n in numbers)


def emcy_alarm_word(manufacturer: bytes) -> int:
    """The alarm word of an EMCY: bytes 3-4 of the frame (the first two manufacturer bytes)."""
    data = bytes(manufacturer[:2]).ljust(2, b'\0')
    return data[0] | data[1] << 8


def decode(node_id: int, node_name: str, data: bytes, timestamp: float) -> EmcyEvent:
    """0x10xx: an error naming the alarms of bytes 3-4; 0x00xx: the reset (info), naming any
    alarm still active; other codes (the drive sends none): CiA 301's reading."""
    event = decode_emcy(node_id, node_name, data, timestamp)
    word = emcy_alarm_word(event.manufacturer)
    high = event.code & 0xFF00
    if high == 0x1000:
        text = alarm_text(word) if word else 'alarm (no alarm bit set in bytes 3-4)'
        return event.with_meaning(text=text, slot=0, severity=Severity.ERROR, reset=False)
    if high == 0x0000:
        left = ', '.join(alarm_name(n) for n in alarm_numbers(word))
        text = 'alarms reset' + (f'; still active: {left}' if word else '')
        return event.with_meaning(text=text, slot=0, severity=Severity.INFO, reset=True)
    return event.with_meaning(slot=0)
