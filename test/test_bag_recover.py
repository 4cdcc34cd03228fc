"""A bridge killed (SIGKILL) mid-recording loses at most the open split: the closed splits are a
readable bag as they are, and ``drive-bridge recover`` makes the open one readable too."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest
import yaml
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.recover import MAGIC, recover, summary_problem
from drive_bridge.bag.source import open_recording
from drive_bridge.bag.typestore import typestore
from drive_bridge.bag.writer import BagWriter
from drive_bridge.cli.main import main
from waittools import wait_for

ROOT = Path(__file__).resolve().parents[1]
TRACES = next((p / 'shared' / 'realdata' / 'traces' for p in ROOT.parents if (p / 'shared').is_dir()), ROOT)


def listed(bag: Path) -> list[str]:
    meta = bag / 'metadata.yaml'
    if not meta.exists():
        return []
    return yaml.safe_load(meta.read_text())['rosbag2_bagfile_information']['relative_file_paths']


def messages_on_disk(split: Path, topic: str = '/can/frames') -> int:
    """The messages of ``topic`` an open split already holds on disk (a split's first chunk may
    hold only other topics: a CI run once recovered 5 messages and no frame)."""
    count, channels = 0, set()
    try:
        with split.open('rb') as stream:
            for record in StreamReader(stream).records:
                if isinstance(record, Channel) and record.topic == topic:
                    channels.add(record.id)
                count += isinstance(record, Message) and record.channel_id in channels
    except Exception:  # the torn tail of an open split
        pass
    return count


@pytest.mark.slow
@pytest.mark.ros  # the bridge (rclpy, simulated drives) in a process of its own
@pytest.mark.sim
def test_killed_bridge_leaves_closed_splits_and_recover_reads_the_open_one(tmp_path: Path) -> None:
    env = {**os.environ, 'PYTHONPATH': str(ROOT), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'ROS_DOMAIN_ID': str(101 + os.getpid() % 100)}
    process = subprocess.Popen(
        [sys.executable, '-c', 'from drive_bridge.cli.bridge import bridge_main; bridge_main()', '--ros-args',
         '-p', 'record.start:=true', '-p', f'record.path:={tmp_path}', '-p', 'record.split_seconds:=1.5'],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        def open_split_has_data() -> Path | None:
            bags = list(tmp_path.iterdir())
            if not bags or not listed(bags[0]):
                return None
            bag = bags[0]
            open_splits = [p for p in bag.glob('*.mcap') if p.name not in listed(bag)]
            return bag if open_splits and messages_on_disk(open_splits[0]) > 0 else None
        bag = wait_for(open_split_has_data, 30, 'a closed split and data in the open one')
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait(10)
    closed = listed(bag)
    open_split, = [p for p in bag.glob('*.mcap') if p.name not in closed]
    assert all(summary_problem(bag / name) == '' for name in closed)
    assert 'not closed' in summary_problem(open_split)
    with pytest.raises(Exception), Reader(open_split) as reader:  # noqa: B017  rosbags cannot read it as it is
        list(reader.messages())
    before = sum(1 for _ in open_recording(bag).frames())  # the closed splits, as they are
    assert before > 1000

    assert main(['recover', str(bag)]) == 0
    assert listed(bag)[-1] == open_split.name and summary_problem(open_split) == ''
    with AnyReader([bag], default_typestore=typestore()) as reader:
        frames = sum(c.msgcount for c in reader.connections if c.topic == '/can/frames')
        assert sum(1 for _ in reader.messages()) == reader.message_count
    after = sum(1 for _ in open_recording(bag).frames())
    assert after == frames > before
    recording = open_recording(open_split)  # the recovered split alone still has the config and EDS
    assert recording.config_yaml and recording.files


def test_recover_refuses_what_is_not_a_bag(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='no such file'):
        recover(tmp_path / 'nothing')
    with pytest.raises(BagError, match='no .mcap split'):
        recover(tmp_path)
    (tmp_path / 'fake.mcap').write_bytes(b'not an mcap file at all')
    with pytest.raises(BagError, match='not an MCAP file'):
        recover(tmp_path / 'fake.mcap')
    (tmp_path / 'notes.txt').write_text('x')
    with pytest.raises(BagError, match='not a rosbag2 MCAP bag'):
        recover(tmp_path / 'notes.txt')


@pytest.mark.skipif(not TRACES.is_dir(), reason='real traces not available')
def test_recover_leaves_a_complete_bag_as_it_is(tmp_path: Path) -> None:
    assert main(['import', str(TRACES / 'pcan2.trc'), '-o', str(tmp_path / 'bag'), '-q']) == 0
    split, = (tmp_path / 'bag').glob('*.mcap')
    mtime = split.stat().st_mtime_ns
    time.sleep(0.01)
    report = recover(tmp_path / 'bag')
    assert [s.rewritten for s in report.splits] == [False] and split.stat().st_mtime_ns == mtime
    assert sum(1 for _ in open_recording(tmp_path / 'bag').frames()) == 6968


@pytest.mark.skipif(not TRACES.is_dir(), reason='real traces not available')
def test_an_empty_split_is_moved_aside_and_the_rest_recovered(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    """A recorder killed within its first second leaves a 0-byte split (its header was still buffered)."""
    bag = tmp_path / 'bag'
    assert main(['import', str(TRACES / 'pcan2.trc'), '-o', str(bag), '-q']) == 0
    (bag / 'bag_1.mcap').write_bytes(b'')
    capsys.readouterr()
    assert main(['info', str(bag)]) == 0
    out = capsys.readouterr().out
    assert '  splits:   1 (bag_0.mcap)' in out
    assert '1 split(s) not in metadata.yaml: run drive-bridge recover (bag_1.mcap)' in out
    assert main(['recover', str(bag)]) == 0
    assert 'bag_1.mcap: 0 messages recovered (0 bytes, no MCAP header' in capsys.readouterr().out
    assert listed(bag) == ['bag_0.mcap'] and (bag / 'bag_1.mcap.empty').exists()
    assert sum(1 for _ in open_recording(bag).frames()) == 6968


def test_a_new_split_has_its_mcap_header_on_disk_at_once(tmp_path: Path) -> None:
    writer = BagWriter(tmp_path / 'bag')
    writer.write_frame(can.Message(arbitration_id=0x701, data=b'\x05', timestamp=1.0))
    split, = (tmp_path / 'bag').glob('*.mcap')
    assert split.read_bytes().startswith(MAGIC)  # before any flush or close
    writer.close()


def test_info_of_a_bag_without_messages_has_no_start(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    BagWriter(tmp_path / 'bag').close()
    assert main(['info', str(tmp_path / 'bag')]) == 0
    out = capsys.readouterr().out
    assert '  start:    (no messages)\n  duration: (no messages)' in out and '2262' not in out
