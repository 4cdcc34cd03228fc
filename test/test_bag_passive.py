"""Passive recording (``drive-bridge record``): listen only, every frame of the bus in the bag,
nothing sent; Ctrl-C closes the bag cleanly."""
from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import can

from bustools import unique_channel
from drive_bridge.bag.recover import summary_problem
from drive_bridge.bag.source import open_recording
from drive_bridge.cli.main import main


def test_passive_record_gets_every_frame_and_sends_none(tmp_path: Path) -> None:
    channel = unique_channel()
    config = tmp_path / 'bus.yaml'
    config.write_text(f'bus: {{interface: virtual, channel: {channel}}}\nnodes: {{}}\n')
    observer = can.Bus(interface='virtual', channel=channel)
    sender = can.Bus(interface='virtual', channel=channel)
    sent = [can.Message(arbitration_id=0x180 + i % 8, data=i.to_bytes(4, 'little'), is_extended_id=False)
            for i in range(3000)]

    def send() -> None:
        time.sleep(0.5)
        for msg in sent:
            sender.send(msg)
    thread = threading.Thread(target=send)
    thread.start()
    try:
        assert main(['record', '--config', str(config), '-o', str(tmp_path / 'bag'), '--duration', '2.0',
                     '-q']) == 0
    finally:
        thread.join()
        seen = []
        while (msg := observer.recv(0)) is not None:
            seen.append(msg)
        observer.shutdown()
        sender.shutdown()
    assert len(seen) == len(sent)  # the recorder sent nothing (no SYNC, NMT, SDO, heartbeat)
    bag = open_recording(tmp_path / 'bag')
    frames = list(bag.frames())
    assert [bytes(m.data) for m in frames] == [bytes(m.data) for m in sent]
    assert all(m.is_rx for m in frames)
    assert bag.config_yaml == config.read_text()


def test_ctrl_c_closes_the_bag(tmp_path: Path, capsys) -> None:
    """Whatever started pytest: SIGINT comes in ignored here, as from a background shell (the
    verb's own handler stops it; before, the signal was dropped and this test hung)."""
    channel = unique_channel()
    sender = can.Bus(interface='virtual', channel=channel)

    def send_then_interrupt() -> None:
        time.sleep(0.5)
        for _ in range(500):  # queued at the recorder's interface as they are sent
            sender.send(can.Message(arbitration_id=0x701, data=[5], is_extended_id=False))
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C: the frames received before it are in the bag
    thread = threading.Thread(target=send_then_interrupt)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        thread.start()
        code = main(['record', '--interface', 'virtual', '--channel', channel, '-o', str(tmp_path / 'bag'), '-q'])
    finally:
        signal.signal(signal.SIGINT, previous)
        thread.join()
        sender.shutdown()
    assert code == 0
    captured = capsys.readouterr()
    assert '500 frames' in captured.out
    assert '(passive: sends nothing; Ctrl-C stops)' in captured.err  # not 'listen only': the controller ACKs
    split, = (tmp_path / 'bag').glob('*.mcap')
    assert summary_problem(split) == ''  # closed: footer and summary written
    assert sum(1 for _ in open_recording(tmp_path / 'bag').frames()) == 500


def test_a_failing_interface_closes_the_bag_and_names_the_interface(tmp_path: Path) -> None:
    from drive_bridge.bag.errors import BagError
    from drive_bridge.bag.passive import record_passive
    from drive_bridge.bag.recorder import Recorder
    channel = unique_channel()
    bus = can.Bus(interface='virtual', channel=channel)
    sender = can.Bus(interface='virtual', channel=channel)
    recorder = Recorder(tmp_path / 'bag')
    errors: list[BaseException] = []

    def run() -> None:
        try:
            record_passive(bus, recorder, threading.Event(), name=f'virtual:{channel}')
        except BaseException as exc:
            errors.append(exc)
    thread = threading.Thread(target=run)
    thread.start()
    for _ in range(5):
        sender.send(can.Message(arbitration_id=0x701, data=b'\x05'))
    time.sleep(0.3)
    bus.shutdown()  # the adapter goes away: recv raises CanOperationError
    thread.join(5)
    sender.shutdown()
    assert len(errors) == 1 and isinstance(errors[0], BagError), errors
    assert f'CAN interface virtual:{channel}: receive failed' in str(errors[0])
    assert sum(1 for _ in open_recording(tmp_path / 'bag').frames()) == 5
