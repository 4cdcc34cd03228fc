"""``local``: a CAN bus shared by the processes of one machine, over Unix datagram sockets.

Without SocketCAN (no ``vcan``) python-can's ``virtual`` bus stays inside one process.
This bus has no hub: every participant binds one datagram socket in a directory named by
the channel and sends each frame to every other socket in that directory, so all
participants see every frame, as on a wire. Timestamps are set on receive. A socket left
behind by a process that died is removed by the first sender that finds it refusing.

A receiver whose kernel queue is full (``net.unix.max_dgram_qlen`` datagrams) holds the
sender back for up to ``send_timeout`` seconds, like a CAN controller that waits for the
bus; after that the frame is dropped for that receiver and counted in ``dropped``.
There is no arbitration, bit timing or error frames: the bit rate is accepted and ignored.
"""
from __future__ import annotations

import errno
import os
import socket
import struct
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import can

from drive_bridge.transport.errors import TransportError

# arbitration id, flags, dlc, 8 data bytes
_FRAME = struct.Struct('<IBB8s')
_EXTENDED, _REMOTE, _ERROR = 1, 2, 4
_SOCKET_SUFFIX = '.sock'
_PATH_MAX = 107  # sun_path is 108 bytes with the terminating NUL
RESCAN_PERIOD = 0.1  # s: the peer directory is re-read at least this often
STAT_PERIOD = 0.005  # s: the directory's mtime (a peer came or left) is looked at most this often
_counter = 0
_counter_lock = threading.Lock()


def channel_directory(channel: str) -> Path:
    """The directory of a channel: the channel itself when it is an absolute path, else
    ``drive_bridge-can-<uid>/<channel>`` under the temporary directory (or $DRIVE_BRIDGE_CAN_DIR)."""
    text = str(channel)
    if os.path.isabs(text):
        return Path(text)
    if not text or '/' in text or text in {'.', '..'}:
        raise TransportError(f'local CAN channel {text!r}: give a name without "/" or an absolute directory')
    base = os.environ.get('DRIVE_BRIDGE_CAN_DIR') or os.path.join(tempfile.gettempdir(),
                                                                  f'drive_bridge-can-{os.getuid()}')
    return Path(base) / text


def _own_name() -> str:
    global _counter
    with _counter_lock:
        _counter += 1
        number = _counter
    return f'{os.getpid()}-{number}-{os.urandom(3).hex()}{_SOCKET_SUFFIX}'


class LocalBus(can.BusABC):
    """One participant of a ``local`` channel (``can.Bus(interface='local', channel='name')``)."""

    def __init__(self, channel: Any = 'drive_bridge', *, receive_own_messages: bool = False,
                 send_timeout: float = 0.05, can_filters: can.typechecking.CanFilters | None = None,
                 **kwargs: Any) -> None:
        kwargs.pop('bitrate', None)  # no bit timing on a socket
        self.directory = channel_directory(channel)
        self.receive_own_messages = receive_own_messages
        self.send_timeout = send_timeout
        self.dropped = 0
        try:
            self.directory.mkdir(parents=True, exist_ok=True, mode=0o700)
        except OSError as exc:
            raise TransportError(f'local CAN channel {channel!r}: cannot create {self.directory}: {exc}') from exc
        self.path = str(self.directory / _own_name())
        if len(self.path.encode()) > _PATH_MAX:
            raise TransportError(f'local CAN channel {channel!r}: socket path {self.path} is longer than '
                                 f'{_PATH_MAX} bytes; use a shorter channel or $DRIVE_BRIDGE_CAN_DIR')
        self._rx = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        try:
            self._rx.bind(self.path)
        except OSError as exc:
            self._rx.close()
            raise TransportError(f'local CAN channel {channel!r}: cannot bind {self.path}: {exc}') from exc
        self._tx = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self._tx.settimeout(send_timeout)
        self._tx_nowait = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self._tx_nowait.setblocking(False)  # for slow peers (a socket with a timeout waits on EAGAIN)
        self._rx_timeout: float | None = -1.0  # what the rx socket is set to (-1: not set yet)
        self._send_lock = threading.Lock()
        self._peers: list[str] = []
        self._slow: set[str] = set()  # peers whose queue was full: sent to without waiting
        self._directory_mtime = -1
        self._scanned = 0.0  # monotonic time of the last directory scan
        self._stated = -STAT_PERIOD  # monotonic time the directory's mtime was last looked at
        self._is_shutdown = False
        self.channel = str(channel)
        self.channel_info = f'local:{self.directory}'
        super().__init__(channel=str(channel), can_filters=can_filters, **kwargs)

    # --- sending ---------------------------------------------------------------------------------

    def _refresh_peers(self) -> None:
        """Re-read the channel's directory when it changed (a participant came or left), and
        at least every RESCAN_PERIOD: before Linux 6.13 the directory's mtime can miss a peer.
        The mtime is looked at most every STAT_PERIOD: a stat per frame cost the cycle thread
        a system call (and a GIL hand-over) for every frame it sent."""
        now = time.monotonic()
        if now - self._stated < STAT_PERIOD:
            return
        self._stated = now
        try:
            mtime = os.stat(self.directory).st_mtime_ns
        except OSError as exc:
            raise TransportError(f'local CAN channel directory {self.directory} is gone: {exc}') from exc
        if mtime == self._directory_mtime and now - self._scanned < RESCAN_PERIOD:
            return
        self._directory_mtime = mtime
        self._scanned = now
        own = self.path
        with os.scandir(self.directory) as entries:
            self._peers = [e.path for e in entries if e.name.endswith(_SOCKET_SUFFIX) and e.path != own]

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        if self._is_shutdown:
            raise TransportError(f'local CAN bus {self.channel_info} is shut down')
        if len(msg.data) > 8 or msg.is_fd:
            raise TransportError(f'local CAN bus carries classic CAN frames (at most 8 bytes), '
                                 f'not {len(msg.data)} bytes on id 0x{msg.arbitration_id:X}')
        flags = ((_EXTENDED if msg.is_extended_id else 0) | (_REMOTE if msg.is_remote_frame else 0)
                 | (_ERROR if msg.is_error_frame else 0))
        datagram = _FRAME.pack(msg.arbitration_id, flags, msg.dlc, bytes(msg.data))
        with self._send_lock:
            self._refresh_peers()
            gone = []
            for peer in self._peers:
                try:
                    if peer in self._slow:  # never wait again for a peer that does not read
                        self._tx_nowait.sendto(datagram, peer)
                        self._slow.discard(peer)
                    else:
                        self._tx.sendto(datagram, peer)
                except (ConnectionRefusedError, FileNotFoundError):
                    gone.append(peer)
                except (TimeoutError, BlockingIOError):
                    self._slow.add(peer)
                    self.dropped += 1
                except OSError as exc:
                    if exc.errno != errno.ENOBUFS:
                        raise TransportError(f'local CAN bus {self.channel_info}: sending to {peer}: {exc}') from exc
                    self.dropped += 1
            if self.receive_own_messages:
                self._tx.sendto(datagram, self.path)
            for peer in gone:  # a process that died without shutting down left its socket
                self._peers.remove(peer)
                try:
                    os.unlink(peer)
                except OSError:
                    pass

    # --- receiving -------------------------------------------------------------------------------

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if timeout != self._rx_timeout:
            self._rx.settimeout(timeout)
            self._rx_timeout = timeout
        try:
            datagram = self._rx.recv(_FRAME.size)
        except (TimeoutError, BlockingIOError):
            return None, False
        except OSError as exc:
            if self._is_shutdown:
                return None, False
            raise TransportError(f'local CAN bus {self.channel_info}: receiving: {exc}') from exc
        stamp = time.time()
        if len(datagram) != _FRAME.size:  # not a frame of this transport: ignored
            return None, False
        arbitration_id, flags, dlc, data = _FRAME.unpack(datagram)
        return can.Message(timestamp=stamp, arbitration_id=arbitration_id, is_extended_id=bool(flags & _EXTENDED),
                           is_remote_frame=bool(flags & _REMOTE), is_error_frame=bool(flags & _ERROR),
                           dlc=dlc, data=data[:dlc] if not flags & _REMOTE else b'', channel=self.channel,
                           is_rx=True, check=False), False

    def fileno(self) -> int:
        return self._rx.fileno()

    def shutdown(self) -> None:
        if self._is_shutdown:
            return
        super().shutdown()
        self._is_shutdown = True
        self._rx.close()
        self._tx.close()
        self._tx_nowait.close()
        try:
            os.unlink(self.path)
        except OSError:
            pass
        try:
            self.directory.rmdir()  # the last participant leaves no directory behind
        except OSError:
            pass
