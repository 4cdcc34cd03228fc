"""One lane of the boundary: a Unix ``SOCK_SEQPACKET`` socket carrying whole messages.

SEQPACKET keeps message boundaries and order and is reliable, so no framing is needed; the
kernel delivers each ``send`` whole or not at all. Records are pickled and read back by an
unpickler that builds only the package's own dataclasses and enums (:data:`CARRIED_PREFIX`): a
message naming any other class (or a function) is refused, so what crosses is typed records,
not arbitrary objects.

Bounds: a message is at most :data:`MAX_MESSAGE` bytes either way (a larger record is refused
before it is sent, naming its type and size); the socket buffers are raised to
:data:`SOCKET_BUFFER` where the kernel allows, so a burst does not block a sender.
"""
from __future__ import annotations

import dataclasses
import enum
import io
import pickle
import socket
import threading
from typing import Any

from drive_bridge.busproc.errors import BoundaryError

MAX_MESSAGE = 256 * 1024  # bytes of one message, either way
SOCKET_BUFFER = 4 * 1024 * 1024  # requested per direction; the kernel may grant less
PROTOCOL = pickle.HIGHEST_PROTOCOL

# What may cross: the dataclasses and enums of drive_bridge's own core modules (records,
# snapshots, events, trajectories, the families' state enums), and nothing of the ROS layer.
CARRIED_PREFIX = 'drive_bridge.'
NOT_CARRIED = ('drive_bridge.ros', 'drive_bridge.cli', 'drive_bridge.sim')
_BUILTINS = {('builtins', 'frozenset'), ('builtins', 'set')}


class _RecordUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        if (module, name) in _BUILTINS:
            return super().find_class(module, name)
        if module.startswith(CARRIED_PREFIX) and not module.startswith(NOT_CARRIED):
            found = super().find_class(module, name)
            if isinstance(found, type) and (dataclasses.is_dataclass(found) or issubclass(found, enum.Enum)):
                return found
        raise BoundaryError(f'a message names {module}.{name}, which the boundary does not carry')


def encode(record: object) -> bytes:
    """The bytes of one record; BoundaryError when over :data:`MAX_MESSAGE`."""
    data = pickle.dumps(record, PROTOCOL)
    if len(data) > MAX_MESSAGE:
        raise BoundaryError(f'{type(record).__name__} of {len(data)} bytes is over the boundary\'s '
                            f'limit of {MAX_MESSAGE} bytes per message')
    return data


def decode(data: bytes) -> object:
    """The record of one message; BoundaryError for anything but a declared record."""
    try:
        return _RecordUnpickler(io.BytesIO(data)).load()
    except BoundaryError:
        raise
    except Exception as exc:
        raise BoundaryError(f'malformed message of {len(data)} bytes: {exc!r}') from None


def lane_pair() -> tuple[socket.socket, socket.socket]:
    """Two connected ends of one lane, with large buffers."""
    ends = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    for end in ends:
        for option in (socket.SO_SNDBUF, socket.SO_RCVBUF):
            try:
                end.setsockopt(socket.SOL_SOCKET, option, SOCKET_BUFFER)
            except OSError:
                pass
    return ends


class Lane:
    """One end of a lane: whole records (or raw bytes) in and out. Sends are serialized by a
    lock (several threads send); ``send_nowait`` never blocks and says whether it was sent."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self._send_lock = threading.Lock()
        self.closed = False

    def fileno(self) -> int:
        return self.sock.fileno()

    def send(self, record: object) -> None:
        """Send one record, waiting while the peer's buffer is full; OSError when the peer is gone."""
        self.send_bytes(encode(record))

    def send_bytes(self, data: bytes) -> None:
        with self._send_lock:
            self.sock.send(data)

    def send_nowait(self, data: bytes) -> bool:
        """Send without waiting; False when the buffer is full (the message is not sent).
        OSError when the peer is gone."""
        try:
            self.sock.send(data, socket.MSG_DONTWAIT)
        except BlockingIOError:
            return False
        return True

    def recv_bytes(self) -> bytes | None:
        """The next message, None at end of stream (the peer closed or died)."""
        try:
            data = self.sock.recv(MAX_MESSAGE + 1)
        except OSError:
            return None
        if not data:
            return None
        if len(data) > MAX_MESSAGE:
            raise BoundaryError(f'a message of over {MAX_MESSAGE} bytes arrived')
        return data

    def recv(self) -> object | None:
        """The next record, None at end of stream; BoundaryError for a message that is not one."""
        data = self.recv_bytes()
        return None if data is None else decode(data)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.sock.close()
