"""The axis' mode after boot, from the drive's 0x6502: the configured mode when the drive has
it, else (an axis whose config names no mode) the best one the bridge can stream. An axis left
without a usable mode says why, and refuses commands and trajectories with that reason."""
from __future__ import annotations

from dataclasses import dataclass

from drive_bridge.cia402.modes import SUPPORT_BITS, Mode, mode_name
from drive_bridge.model import ModeChoice

STREAMING_ORDER = (int(Mode.CYCLIC_SYNC_POSITION), int(Mode.INTERPOLATED_POSITION), int(Mode.PROFILE_VELOCITY))


@dataclass(frozen=True)
class BootMode:
    mode: int
    problem: str  # '' when ``mode`` can be used
    note: str  # the start-up line: which mode and why


def support_text(supported: int | None) -> str:
    if supported is None:
        return 'modes unknown (no 0x6502)'
    names = ', '.join(mode_name(m) for m, bit in SUPPORT_BITS.items() if supported >> bit & 1) or 'none'
    return f'0x6502 = 0x{supported:08X}: {names}'


def has_mode(supported: int | None, mode: int) -> bool:
    bit = SUPPORT_BITS.get(Mode(mode)) if mode in Mode._value2member_map_ else None
    return supported is None or bit is None or bool(supported >> bit & 1)


def pick(configured: int, auto: ModeChoice | None, supported: int | None, inferred: bool) -> BootMode:
    """``supported``: 0x6502 as read (or as inferred from the EDS when ``inferred``)."""
    source = support_text(supported) + (' inferred from the EDS objects' if inferred else '')
    if auto is None:
        if has_mode(supported, configured):
            return BootMode(configured, '', f'mode {mode_name(configured)} as configured ({source})')
        return BootMode(configured, f'the configured mode {mode_name(configured)} is not supported by the drive '
                                    f'({source}); set another mode (axis key `mode`)', '')
    candidates = STREAMING_ORDER if auto.candidates is None else auto.candidates  # None: the map was not derived
    for mode in candidates:
        if has_mode(supported, mode):
            how = ' through the bridge\'s position loop' if mode == Mode.PROFILE_VELOCITY else ''
            return BootMode(mode, '', f'mode {mode_name(mode)}{how}, the best streaming mode of the drive ({source})')
    streams = ', '.join(mode_name(m) for m in candidates) or 'no mode'
    return BootMode(int(Mode.NO_MODE), f'no mode the bridge can stream: the drive has {source}, its PDO map '
                                       f'streams {streams}', '')
