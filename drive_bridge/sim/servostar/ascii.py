"""The SERVOSTAR's ASCII terminal over PDO 21 [2.6, 2.7, 9.7]: RPDO 21 frames carry up to 8
characters; NUL bytes are padding; a command ends with CR LF. The answer (the value, or nothing
for a write or command) is sent with CR LF and the prompt on every TPDO channel carrying PDO 21,
8 characters a frame. The commands are the object channel's (0x3500+, one name per object,
the value at sub 1): ``NAME`` reads, ``NAME value`` writes (with the checks and effects of an
SDO write of sub 1), a command (SAVE, COLDSTART, CLRFAULT) runs. The manual's byte tables are
lost: the prompt ``-->`` and the error texts are the simulator's."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.servostar.objects import VALUE
from drive_bridge.sim.store import ObjectStore, key

PROMPT = b'-->'
COMMANDS = frozenset({'SAVE', 'COLDSTART', 'CLRFAULT'})


def channel_names(store: ObjectStore) -> dict[str, int]:
    """ASCII name -> object-channel index, from the EDS names ("PTBASE value")."""
    names = {}
    for k, var in store.variables.items():
        index, sub = k >> 8, k & 0xFF
        if 0x3500 <= index <= 0x39FF and sub == VALUE and var.name.endswith(' value'):
            names[var.name[:-len(' value')].upper()] = index
    return names


class AsciiTerminal:
    """Command buffer and interpreter of PDO 21 (module docstring)."""

    def __init__(self, store: ObjectStore, write: Callable[[int, Any], None], read: Callable[[int], Any],
                 send: Callable[[bytes], int]) -> None:
        self._store = store
        self._write = write
        self._read = read
        self._send = send
        self.names = channel_names(store)
        self.buffer = bytearray()
        self.log: list[tuple[str, str]] = []  # (command, answer) for tests

    def receive(self, data: bytes) -> None:
        for byte in data:
            if byte == 0:
                continue
            self.buffer.append(byte)
            if self.buffer.endswith(b'\r\n'):
                line = self.buffer[:-2].decode('latin-1').strip()
                self.buffer.clear()
                if line:
                    answer = self.execute(line)
                    self.log.append((line, answer))
                    self._send((answer + '\r\n').encode('latin-1') + PROMPT)

    def execute(self, line: str) -> str:
        words = line.split()
        name = words[0].upper()
        index = self.names.get(name)
        if index is None:
            return 'Error: unknown command'
        try:
            if name in COMMANDS:
                self._write(index, 0)
                return ''
            if len(words) == 1:
                return str(self._read(index))
            var = self._store.variables[key(index, VALUE)]
            if not var.writable:
                return 'Error: read-only'
            try:
                value = int(words[1], 0)
            except ValueError:
                return 'Error: invalid argument'
            if (var.min is not None and value < var.min) or (var.max is not None and value > var.max):
                return 'Error: value out of range'
            self._write(index, value)
            return ''
        except SdoAbortedError as exc:
            return f'Error: 0x{exc.code:08X}'
