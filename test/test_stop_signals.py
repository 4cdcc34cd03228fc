"""SIGINT and SIGTERM stop the tools whatever disposition they inherited.

A process started in the background by a non-interactive shell inherits SIGINT as ignored;
Python then installs no KeyboardInterrupt handler, and ``drive-bridge record`` recorded for
ever (a fresh clone's ``make test`` hung here). Each process below starts as such a shell
starts it: SIGINT ignored, stdin not a terminal (shelltools.from_background_shell).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO

import can
import pytest

from drive_bridge.bag.recover import summary_problem
from drive_bridge.bag.source import open_recording
from drive_bridge.bag.writer import BagWriter
from drive_bridge.stopsignals import StopSignal, exit_code, stop_on_signals
from shelltools import from_background_shell
from waittools import wait_for

TOOL = Path(sys.executable).parent / 'drive-bridge'
STOP_TIMEOUT = 30.0  # s from the signal to the exit: generous, a busy machine's start-up included


@pytest.fixture
def can_dir() -> Iterator[Path]:
    """A short directory of ``local`` channels (socket paths have a 107-byte limit)."""
    with tempfile.TemporaryDirectory(prefix='sig-') as path:
        yield Path(path)


class Tool:
    """``drive-bridge ARGS`` in a process of its own, started as a background shell starts it;
    its output is collected as it comes (progress lines end with a carriage return)."""

    def __init__(self, args: list[str], can_dir: Path) -> None:
        env = {**os.environ, 'DRIVE_BRIDGE_CAN_DIR': str(can_dir)}
        self.process = subprocess.Popen(from_background_shell([str(TOOL), *args]), stdout=subprocess.PIPE,
                                        stderr=subprocess.PIPE, env=env)
        self.can_dir = can_dir
        self.out, self.err = bytearray(), bytearray()
        self._readers = [threading.Thread(target=self._read, args=(stream, into), daemon=True)
                         for stream, into in ((self.process.stdout, self.out), (self.process.stderr, self.err))]
        for reader in self._readers:
            reader.start()

    @staticmethod
    def _read(stream: IO[bytes], into: bytearray) -> None:
        while chunk := stream.read1(4096):  # type: ignore[attr-defined]
            into += chunk

    def sockets(self) -> list[Path]:
        """The ``local`` bus sockets this process has open (gone once it released its bus)."""
        return list(self.can_dir.glob(f'*/{self.process.pid}-*.sock'))

    def stop(self, signum: int) -> tuple[int, str, str]:
        """Send ``signum``; the exit code, stdout and stderr."""
        self.process.send_signal(signum)
        try:
            self.process.wait(timeout=STOP_TIMEOUT)
        except subprocess.TimeoutExpired:
            self.process.kill()
            pytest.fail(f'still running {STOP_TIMEOUT:.0f} s after {signal.Signals(signum).name}: '
                        f'{self.err.decode(errors="replace")[-500:]}')
        for reader in self._readers:
            reader.join(5)
        return self.process.returncode, self.out.decode(), self.err.decode(errors='replace')


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_record_stops_on_the_signal_and_closes_the_bag(tmp_path: Path, can_dir: Path, signum: int) -> None:
    tool = Tool(['record', '--interface', 'local', '--channel', 'rec', '-o', str(tmp_path / 'bag')], can_dir)
    try:
        wait_for(tool.sockets, 60, 'the recorder on the bus')
        with can.Bus(interface='local', channel=str(can_dir / 'rec')) as sender:
            for i in range(200):
                sender.send(can.Message(arbitration_id=0x181, data=i.to_bytes(2, 'little'), is_extended_id=False))
        wait_for(lambda: b'200 frames' in tool.err, 30, 'the 200 frames recorded (progress line)')
        code, out, err = tool.stop(signum)
    finally:
        tool.process.kill()
    assert code == 0, err  # the signal is how a recording ends
    assert '200 frames, 0 messages, 0 dropped' in out
    split, = (tmp_path / 'bag').glob('*.mcap')
    assert summary_problem(split) == ''  # closed: footer and summary written
    assert [int.from_bytes(m.data, 'little') for m in open_recording(tmp_path / 'bag').frames()] == list(range(200))
    assert not tool.sockets(), 'the bus released'


@pytest.fixture(scope='module')
def long_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """60 s of one frame every 10 ms: a replay that is still running when it is stopped."""
    path = tmp_path_factory.mktemp('stop') / 'long'
    with BagWriter(path) as writer:
        for i in range(6000):
            writer.write_frame(can.Message(timestamp=1.7e9 + i * 0.01, arbitration_id=0x181, is_extended_id=False,
                                           data=i.to_bytes(2, 'little')), 'can0')
    return path


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_replay_onto_a_bus_is_interrupted_releases_the_bus_and_says_so(long_bag: Path, can_dir: Path,
                                                                       signum: int) -> None:
    with can.Bus(interface='local', channel=str(can_dir / 'out')) as receiver:
        tool = Tool(['replay', str(long_bag), '--onto', '--interface', 'local', '--channel', 'out', '--quiet'],
                    can_dir)
        try:
            assert receiver.recv(60) is not None, 'the replay started'
            code, _out, err = tool.stop(signum)
        finally:
            tool.process.kill()
    assert code == 128 + signum, err  # interrupted in its work: 130 / 143, as a shell reports it
    assert f'drive-bridge replay: stopped by {signal.Signals(signum).name}' in err
    assert 'Traceback' not in err
    assert not tool.sockets(), 'the bus released'


@pytest.mark.sim
def test_sim_stops_on_sigint_and_releases_the_bus(can_dir: Path) -> None:
    config = Path(__file__).resolve().parent.parent / 'config' / 'demo.yaml'
    tool = Tool(['sim', str(config), '--interface', 'local', '--channel', 'sim'], can_dir)
    try:
        wait_for(lambda: b'simulating' in tool.out, 60, 'the drives simulated')
        code, _out, err = tool.stop(signal.SIGINT)
    finally:
        tool.process.kill()
    assert code == 0, err
    assert not tool.sockets() and 'Traceback' not in err


# --- the mechanism, in this process ---------------------------------------------------------------

def test_a_polling_loop_sees_the_request_and_a_second_signal_interrupts() -> None:
    before = signal.getsignal(signal.SIGTERM)
    with stop_on_signals() as request:
        assert not request.requested
        os.kill(os.getpid(), signal.SIGTERM)
        assert request.wait(5) and request.signum == signal.SIGTERM
        with pytest.raises(StopSignal) as raised:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)  # the handler raises in this thread as soon as it runs
        assert raised.value.signum == signal.SIGINT and exit_code(raised.value) == 130
    assert signal.getsignal(signal.SIGTERM) is before


def test_interrupt_mode_raises_at_the_first_signal_even_where_sigint_came_in_ignored() -> None:
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with pytest.raises(StopSignal) as raised, stop_on_signals(interrupt=True):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        assert exit_code(raised.value) == 130 and isinstance(raised.value, KeyboardInterrupt)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN  # put back as it was
    finally:
        signal.signal(signal.SIGINT, previous)
    assert exit_code(KeyboardInterrupt()) == 130


def test_outside_the_main_thread_nothing_is_installed() -> None:
    handlers: list[object] = []

    def worker() -> None:
        with stop_on_signals() as request:
            handlers.append(signal.getsignal(signal.SIGTERM))
            assert not request.requested
    before = signal.getsignal(signal.SIGTERM)
    thread = threading.Thread(target=worker)
    thread.start()
    thread.join(5)
    assert handlers == [before]
