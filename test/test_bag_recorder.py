"""The recorder's bounds: a full queue drops and counts (never blocks the caller), a failing
write stops the recording with the reason, and what was written before stays readable."""
from __future__ import annotations

import threading
import time
from pathlib import Path

import can

from drive_bridge.bag.recorder import Recorder
from drive_bridge.bag.source import open_recording
from drive_bridge.bag.writer import string_cdr
from waittools import wait_for


def frame(i: int) -> can.Message:
    return can.Message(timestamp=1.7e9 + i * 1e-4, arbitration_id=0x181, data=i.to_bytes(4, 'little'),
                       is_extended_id=False)


def test_a_full_queue_drops_and_counts_without_blocking(tmp_path: Path) -> None:
    entered, release = threading.Event(), threading.Event()

    def slow_serialize(text: str) -> bytes:  # holds the writer thread, as a stalled disk would
        entered.set()
        release.wait(10)
        return string_cdr(text)
    recorder = Recorder(tmp_path / 'bag', queue_frames=500)
    recorder.add_message('/note', 'std_msgs/msg/String', int(1.7e18), 'hold', slow_serialize)
    assert entered.wait(5)
    started = time.monotonic()
    for i in range(550):
        recorder.on_frame(frame(i))
    assert time.monotonic() - started < 5.0  # the producer never waited (for the held writer: 10 s)
    assert recorder.stats().dropped == 50 and recorder.stats().queued == 500
    release.set()
    stats = recorder.stop()
    assert (stats.frames, stats.dropped, stats.error) == (500, 50, '')
    assert [int.from_bytes(m.data, 'little') for m in open_recording(tmp_path / 'bag').frames()] == list(range(500))


def test_a_failing_write_stops_recording_and_says_why(tmp_path: Path) -> None:
    recorder = Recorder(tmp_path / 'bag')
    for i in range(100):
        recorder.on_frame(frame(i))
    wait_for(lambda: recorder.stats().frames == 100, 5, 'frames written')
    recorder.add_message('/x', 'no_such_pkg/msg/Thing', int(1.7e18), b'\x00\x01\x00\x00')
    wait_for(lambda: recorder.stats().error, 5, 'the write error')
    recorder.on_frame(frame(100))
    stats = recorder.stop()
    assert 'unknown message type' in stats.error and stats.dropped == 1
    assert sum(1 for _ in open_recording(tmp_path / 'bag').frames()) == 100


def test_a_can_fd_frame_is_dropped_with_its_reason(tmp_path: Path) -> None:
    recorder = Recorder(tmp_path / 'bag')
    recorder.on_frame(frame(1))
    recorder.on_frame(can.Message(arbitration_id=0x181, data=bytes(12), is_fd=True, bitrate_switch=True))
    recorder.on_frame(frame(2))
    stats = recorder.stop()
    assert (stats.frames, stats.dropped, stats.dropped_fd) == (2, 1, 1)
    assert '1 dropped (1 CAN FD frames: a bag holds classic CAN only)' in stats.summary()
    assert [f.dlc for f in open_recording(tmp_path / 'bag').frames()] == [frame(1).dlc, frame(2).dlc]
