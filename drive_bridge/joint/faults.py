"""What a refusal says when an axis is in fault: the cause as the drive reported it (the last
EMCY with its code, text and time; the drive's error code where it has one, e.g. 0x603F) and
the way out (the services that clear it), instead of a bare "not enabled"."""
from __future__ import annotations

import time

from drive_bridge.cia301.emcy import EmcyEvent

WAY_OUT = 'clear it with ~/fault_reset and then ~/enable, or both at once with ~/recover'


def emcy_text(event: EmcyEvent) -> str:
    """'last EMCY 0x2310 continuous over-current at 12:03:04.512'."""
    stamp = time.strftime('%H:%M:%S', time.localtime(event.timestamp)) + f'.{int(event.timestamp * 1000) % 1000:03d}'
    return f'last EMCY 0x{event.code:04X} {event.text} at {stamp}'


def fault_refusal(last_emcy: EmcyEvent | None, details: list[str]) -> str:
    """'in fault (last EMCY ..., 0x603F error code 0x2310): clear it with ...'."""
    causes = ([emcy_text(last_emcy)] if last_emcy is not None else ['no EMCY received']) + details
    return f'in fault ({"; ".join(causes)}): {WAY_OUT}'
