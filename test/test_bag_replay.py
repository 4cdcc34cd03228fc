"""``drive-bridge replay --onto``: frames go onto a virtual bus with their recorded timing."""
from __future__ import annotations

import threading
from pathlib import Path

import can
import numpy as np
import pytest

from bench.reactions import recorded_cycle as recorded_frames
from bustools import unique_channel
from drive_bridge.bag.writer import BagWriter
from drive_bridge.cli.main import main
from timingtools import BUSY_SLACK

# The replay is paced: it lasts as long as the recording (a burst would take milliseconds) and
# the median inter-frame error stays small. Its figures (p50 ~10-30 us, p99 ~50 us on an idle
# machine; a busy one adds stalls of a few ms to 0.4 s) are measured by `python -m bench
# reactions --cases replay` beside the machine's floor.
P50_BOUND = 0.002  # s


@pytest.fixture(scope='module')
def bag(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp('replay') / 'raw'
    with BagWriter(path) as writer:  # replay onto a bus needs no config
        for msg in recorded_frames():
            writer.write_frame(msg, 'can0')
    return path


def replay(args: list[str], channel: str) -> list[can.Message]:
    """Run the verb and collect what a second node on the channel receives."""
    received: list[can.Message] = []
    done = threading.Event()
    with can.Bus(interface='virtual', channel=channel) as receiver:
        def collect() -> None:
            while True:
                msg = receiver.recv(0.05)
                if msg is not None:
                    received.append(msg)
                elif done.is_set():
                    return
        thread = threading.Thread(target=collect)
        thread.start()
        try:
            assert main(['replay', *args, '--onto', '--interface', 'virtual', '--channel', channel, '--quiet']) == 0
        finally:
            done.set()
            thread.join(5)
    return received


def test_replay_keeps_the_inter_frame_timing(bag, capsys) -> None:
    original = recorded_frames()
    received = replay([str(bag)], unique_channel('replay'))
    assert [(m.arbitration_id, bytes(m.data)) for m in received] == \
        [(m.arbitration_id, bytes(m.data)) for m in original]
    span = original[-1].timestamp - original[0].timestamp
    took = received[-1].timestamp - received[0].timestamp
    assert 0.9 * span <= took < span + BUSY_SLACK, (took, span)
    error = np.abs(np.diff([m.timestamp for m in received]) - np.diff([m.timestamp for m in original]))
    assert np.percentile(error, 50) < P50_BOUND, f'p50 {np.percentile(error, 50) * 1e6:.0f} us'
    span = received[-1].timestamp - received[0].timestamp
    assert span == pytest.approx(original[-1].timestamp - original[0].timestamp, abs=0.05)
    out = capsys.readouterr().out
    assert f'frames sent       {len(original)} (0 filtered out' in out and 'p99' in out


def test_node_and_direction_filters_and_speed(bag, capsys) -> None:
    both = replay([str(bag), '--node', '2', '3', '--direction', 'tx', '--speed', '4'], unique_channel('replay'))
    assert {m.arbitration_id for m in both} == {0x202, 0x203}  # SYNC is no node's frame
    capsys.readouterr()
    original = [m for m in recorded_frames() if m.is_rx and m.arbitration_id & 0x7F == 3]
    received = replay([str(bag), '--node', '3', '--direction', 'rx', '--speed', '2'], unique_channel('replay'))
    assert [m.arbitration_id for m in received] == [m.arbitration_id for m in original]
    assert {m.arbitration_id for m in received} == {0x183, 0x703}
    span = received[-1].timestamp - received[0].timestamp
    # twice as fast: 0.4 s, not 0.8 s (a late last frame on a busy machine: up to 0.15 s more)
    assert span == pytest.approx((original[-1].timestamp - original[0].timestamp) / 2, abs=0.15)
    assert f'({len(recorded_frames()) - len(original)} filtered out' in capsys.readouterr().out


def test_replay_errors_name_what_is_wrong(bag, tmp_path, capsys) -> None:
    assert main(['replay', str(bag), '--onto']) == 2
    assert '--channel' in capsys.readouterr().err
    assert main(['replay', str(bag), '--onto', '--channel', 'can0']) == 2  # no silent 'virtual' bus
    assert 'give the bus with --interface and --channel' in capsys.readouterr().err
    assert main(['replay', str(bag), '--onto', '--interface', 'virtual', '--channel', 'x', '--speed', '0']) == 2
    assert 'speed 0' in capsys.readouterr().err
    assert main(['replay', str(bag), '--onto', '--interface', 'nonesuch', '--channel', 'x']) == 2
    assert "interface='nonesuch'" in capsys.readouterr().err
    assert main(['replay', str(tmp_path / 'nope.trc'), '--onto', '--interface', 'virtual', '--channel', 'x']) == 2
    assert 'nope.trc' in capsys.readouterr().err
