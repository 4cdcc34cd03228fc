"""candump's text outputs: the log format (``candump -L``, what canplayer reads) and the screen
format people paste into issues (``  can0  589   [8]  43 6C 60 00 ...``, with or without
``-t`` time stamps, ``-x`` direction columns, trailing comments or ASCII).

Read by hand into raw frames ``(time s, identifier, flags, data)``: python-can's readers build
one ``can.Message`` per line, which is most of a diagnosis' time on a long log (and python-can
has no reader for the screen format). ``frames()`` users get ``can.Message`` objects from the
same parse. A screen paste without time stamps gets time 0 for every frame: the diagnosis
then says that timing findings are not available.

Error frames: SocketCAN sets CAN_ERR_FLAG (0x20000000) in the identifier, which candump prints
as an 8-digit identifier (``20000004#...``); python-can reads those as extended data frames.
"""
from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from drive_bridge.bag.errors import BagError

RawFrame = tuple[float, int, int, bytes]  # (time s, identifier, flags, data)
EXT, RTR, ERR, TX, FD = 1, 2, 4, 8, 16
ERR_FLAG = 0x20000000
_HEX = frozenset('0123456789abcdefABCDEF')
SCREEN = re.compile(
    r'^\s*(?:\((?P<t>\d+(?:\.\d+)?)\)\s+)?(?:(?P<chan>[A-Za-z][\w.-]*\d)\s+)?'
    r'(?:(?P<dir>TX|RX)\s+(?:[-B]\s+[-BE]\s+)?)?(?P<id>[0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})\s+'
    r'\[(?P<dlc>\d{1,2})\](?P<rest>.*)$')
LOG = re.compile(r'^\s*\(\d+(?:\.\d+)?\)\s+\S+\s+[0-9A-Fa-f]{3,8}#')


def _flags_of(ident: int, digits: int) -> tuple[int, int]:
    """(identifier, flags): 8 hex digits are an extended identifier or, with CAN_ERR_FLAG, an error frame."""
    if digits <= 3:
        return ident, 0
    if ident & ERR_FLAG:
        return ident & 0x1FFFFFFF, ERR | EXT
    return ident, EXT


def parse_log_line(line: str) -> RawFrame:
    """``(1699584944.440580) can0 701#00`` (``R`` after ``#``: remote; ``##`` CAN FD is refused)."""
    close = line.index(')')
    t = float(line[line.index('(') + 1:close])
    fields = line[close + 1:].split()
    frame = fields[1]
    ident_text, sep, data_text = frame.partition('#')
    if not sep:
        raise ValueError(f'no "#" in {frame!r}')
    ident, flags = _flags_of(int(ident_text, 16), len(ident_text))
    if len(fields) > 2 and fields[2] == 'T':
        flags |= TX
    if data_text.startswith('#'):  # CAN FD: ##<flags nibble><data>
        return t, ident, flags | FD, bytes.fromhex(data_text[2:])
    if data_text[:1] in ('R', 'r'):
        return t, ident, flags | RTR, bytes(int(data_text[1:] or 0) if data_text[1:].isdigit() else 0)
    return t, ident, flags, bytes.fromhex(data_text)


def parse_screen_line(line: str) -> RawFrame | None:
    """One line of candump's screen output; None for a line that is no frame (a comment, "...")."""
    match = SCREEN.match(line)
    if match is None:
        return None
    ident_text = match['id']
    ident, flags = _flags_of(int(ident_text, 16), len(ident_text))
    dlc = int(match['dlc'])
    rest = match['rest']
    if match['dir'] == 'TX':
        flags |= TX
    if 'remote request' in rest:
        return float(match['t'] or 0.0), ident, flags | RTR, bytes(min(dlc, 8))
    if 'ERRORFRAME' in rest:
        flags |= ERR
    out = bytearray()
    for token in rest.split():
        if len(out) == dlc or len(token) != 2 or not (token[0] in _HEX and token[1] in _HEX):
            break
        out.append(int(token, 16))
    if len(out) != dlc and dlc <= 8:
        raise ValueError(f'DLC {dlc} but {len(out)} data byte(s)')
    return float(match['t'] or 0.0), ident, flags, bytes(out)


def read_log(path: Path, strict: bool, skipped: list[str]) -> Iterator[RawFrame]:
    """The frames of a ``candump -L`` log; BagError naming the line where it breaks (strict)."""
    for frame, _channel in _read_log(path, strict, skipped, False):
        yield frame


def read_log_channels(path: Path, strict: bool, skipped: list[str]) -> Iterator[tuple[RawFrame, str]]:
    """The frames of a ``candump -L`` log with the interface each came on (for bags, replay)."""
    return _read_log(path, strict, skipped, True)


def _read_log(path: Path, strict: bool, skipped: list[str], channels: bool) -> Iterator[tuple[RawFrame, str]]:
    """Line by line, the common line inline (a split, a float, a hex decode: per line, faster in
    CPython than a regular expression over the whole file); the rest by ``parse_log_line``."""
    fromhex = bytes.fromhex
    identifiers: dict[str, int] = {}  # '701' -> 0x701, parsed once per COB-ID
    with path.open('r', encoding='latin-1', newline='') as stream:
        for number, line in enumerate(stream, start=1):
            try:  # the common line inline: (1699584944.440580) can0 701#00
                fields = line.split()
                frame = fields[2]
                if len(fields) == 3 and frame[3] == '#' and frame[4:5] not in ('R', 'r', '#'):
                    text = frame[:3]
                    ident = identifiers.get(text)
                    if ident is None:
                        ident = identifiers[text] = int(text, 16)
                    yield (float(fields[0][1:-1]), ident, 0, fromhex(frame[4:])), fields[1]
                else:
                    yield parse_log_line(line), fields[1]
            except (ValueError, IndexError) as exc:
                if not line.strip():
                    continue
                problem = f'line {number}: not a candump -L frame ({exc}): {line.strip()[:60]!r}'
                if strict:
                    raise BagError(f'{path}: {problem}') from None
                skipped.append(problem)


def read_screen(path: Path, strict: bool, skipped: list[str]) -> Iterator[RawFrame]:
    """The frames of pasted candump screen output; lines that are no frame (a shell prompt, a
    comment, "...") are skipped and counted, a frame line that contradicts itself is an error."""
    others = 0
    with path.open('r', encoding='latin-1', newline='') as stream:
        for number, line in enumerate(stream, start=1):
            try:
                frame = parse_screen_line(line)
            except ValueError as exc:
                problem = f'line {number}: {exc}: {line.strip()[:60]!r}'
                if strict:
                    raise BagError(f'{path}: {problem}') from None
                skipped.append(problem)
                continue
            if frame is None:
                others += bool(line.strip())
                continue
            yield frame
    if others:
        skipped.append(f'{others} line(s) that are no frame (comments, "...", a prompt) skipped')


def looks_like(lines: list[str]) -> str | None:
    """'candump' (-L log) or 'candump-screen' when most frame-like lines of a file's head are."""
    log = screen = 0
    for line in lines:
        if LOG.match(line):
            log += 1
        elif SCREEN.match(line):
            screen += 1
    if not log and not screen:
        return None
    return 'candump' if log >= screen else 'candump-screen'
