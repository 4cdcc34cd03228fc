"""The ``local`` CAN transport: frames between processes over Unix sockets, no hub."""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import textwrap
import time
import uuid
from pathlib import Path

import can
import pytest

from drive_bridge.errors import DriveBridgeError
from drive_bridge.master.bus import open_bus
from drive_bridge.transport.local import LocalBus, channel_directory

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def channel(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    monkeypatch.setenv('DRIVE_BRIDGE_CAN_DIR', str(tmp_path))
    return f'test-{uuid.uuid4().hex[:6]}'


def frame(can_id: int, data: bytes = b'', extended: bool = False) -> can.Message:
    return can.Message(arbitration_id=can_id, data=data, is_extended_id=extended)


def test_every_other_participant_sees_a_frame_and_the_sender_only_if_asked(channel: str) -> None:
    a, b = open_bus('local', channel), open_bus('local', channel, receive_own_messages=True)
    c = LocalBus(channel)
    try:
        a.send(frame(0x181, b'\x01\x02\x03'))
        for bus in (b, c):
            got = bus.recv(2.0)
            assert got is not None and got.arbitration_id == 0x181 and bytes(got.data) == b'\x01\x02\x03'
            assert got.is_rx and got.timestamp > 0
        assert a.recv(0.05) is None
        b.send(frame(0x80))
        assert [m.arbitration_id for m in (a.recv(2.0), b.recv(2.0), c.recv(2.0)) if m] == [0x80] * 3
        a.send(frame(0x18FF50E5, b'\xff', extended=True))
        got = c.recv(2.0)
        assert got is not None and got.is_extended_id and got.arbitration_id == 0x18FF50E5
    finally:
        for bus in (a, b, c):
            bus.shutdown()
    assert not channel_directory(channel).exists()  # the last one leaves nothing behind


def test_frames_cross_processes_both_ways(channel: str) -> None:
    echo = textwrap.dedent(f'''
        import can, sys
        from drive_bridge.master.bus import open_bus
        bus = open_bus('local', {channel!r})
        print('ready', flush=True)
        for _ in range(200):
            msg = bus.recv(10)
            bus.send(can.Message(arbitration_id=msg.arbitration_id + 1, data=msg.data, is_extended_id=False))
        bus.shutdown()
    ''')
    env = {**os.environ, 'PYTHONPATH': str(REPO)}
    child = subprocess.Popen([sys.executable, '-c', echo], stdout=subprocess.PIPE, text=True, env=env)
    bus = LocalBus(channel)
    try:
        assert child.stdout is not None and child.stdout.readline().strip() == 'ready'
        replies = []
        for n in range(200):
            bus.send(frame(0x200, n.to_bytes(2, 'little')))
            reply = bus.recv(10.0)
            assert reply is not None
            replies.append((reply.arbitration_id, int.from_bytes(reply.data, 'little')))
        assert replies == [(0x201, n) for n in range(200)]
        assert child.wait(10) == 0
    finally:
        child.kill()
        bus.shutdown()


def test_a_socket_left_by_a_dead_process_is_removed_not_fatal(channel: str) -> None:
    bus = LocalBus(channel)
    stale = channel_directory(channel) / '999999-1-dead.sock'
    orphan = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    orphan.bind(str(stale))
    orphan.close()  # the file stays, nobody listens: what a killed process leaves
    try:
        bus.send(frame(0x80))
        assert not stale.exists()
        bus.send(frame(0x80))
    finally:
        bus.shutdown()


def test_bad_channel_and_frames_are_refused_with_the_reason(channel: str) -> None:
    with pytest.raises(DriveBridgeError, match='without "/"'):
        LocalBus('a/b')
    bus = LocalBus(channel)
    try:
        with pytest.raises(can.CanError, match='at most 8 bytes'):
            bus.send(can.Message(arbitration_id=1, data=bytes(12), is_fd=True, is_extended_id=False))
    finally:
        bus.shutdown()
    with pytest.raises(can.CanError, match='shut down'):
        bus.send(frame(0x80))


def test_a_peer_that_does_not_read_costs_the_sender_one_timeout_not_one_per_frame(channel: str) -> None:
    sender, stalled, reader = LocalBus(channel), LocalBus(channel), LocalBus(channel)
    try:
        started = time.monotonic()
        for i in range(3000):  # far more than a datagram queue holds: the stalled peer's fills
            sender.send(frame(0x100 + i % 16))
        took = time.monotonic() - started
        # 50 ms for each dropped frame before (minutes); one timeout now (about 0.1 s idle)
        assert sender.dropped > 100 and took < 5.0, (sender.dropped, took)
        while stalled.recv(0) is not None:  # it reads again: it gets frames again
            pass
        sender.send(frame(0x7FF))
        sender.send(frame(0x7FE))
        got = [m.arbitration_id for m in iter(lambda: stalled.recv(0.5), None)]
        assert got[-2:] == [0x7FF, 0x7FE]
        assert reader.recv(1.0) is not None
    finally:
        for bus in (sender, stalled, reader):
            bus.shutdown()
