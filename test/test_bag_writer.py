"""The bag interface (typestore, BagWriter, open_recording): frames round-trip losslessly,
splits are complete MCAP files, the stored files come back, bad input is a BagError."""
from __future__ import annotations

from pathlib import Path

import can
import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.source import open_recording
from drive_bridge.bag.typestore import typestore
from drive_bridge.bag.writer import FRAME_TYPE, BagWriter

EDS = b'[DeviceInfo]\nVendorName=M\xf6ller\n'  # latin-1, as some vendor EDS files are


def frames(n: int, t0: float = 1.7e9) -> list[can.Message]:
    return [can.Message(timestamp=t0 + i * 1e-3, arbitration_id=(0x181 + i % 4) if i % 7 else 0x1ABCDE,
                        is_extended_id=not i % 7, is_remote_frame=i % 11 == 0, dlc=i % 9,
                        data=b'' if i % 11 == 0 else bytes(range(i % 9)), is_rx=bool(i % 2), channel='vcan0')
            for i in range(n)]


def same(a: can.Message, b: can.Message) -> bool:
    return (abs(a.timestamp - b.timestamp) < 1e-6 and a.arbitration_id == b.arbitration_id
            and a.is_extended_id == b.is_extended_id and a.is_remote_frame == b.is_remote_frame
            and a.dlc == b.dlc and bytes(a.data) == bytes(b.data) and a.is_rx == b.is_rx
            and a.channel == b.channel)


def test_frames_round_trip_through_split_bag(tmp_path: Path) -> None:
    sent = frames(30_000)
    bag = tmp_path / 'run'
    with BagWriter(bag, split_bytes=300_000, config_yaml='bus: {channel: x}\n', files={'d.eds': EDS}) as writer:
        for msg in sent:
            writer.write_frame(msg)
    splits = sorted(bag.glob('*.mcap'))
    assert len(splits) >= 2 and (bag / 'metadata.yaml').exists()
    recording = open_recording(bag)
    assert recording.format == 'rosbag2-mcap'
    assert recording.config_yaml == 'bus: {channel: x}\n'
    assert recording.files['d.eds'].decode('utf-8') == EDS.decode('latin-1')
    got = list(recording.frames())
    assert len(got) == len(sent) and all(same(a, b) for a, b in zip(sent, got, strict=True))
    # every split opens alone (mcap and rosbags) and carries the config
    total = 0
    for split in splits:
        with split.open('rb') as stream:
            summary = make_reader(stream).get_summary()
        assert summary is not None and summary.statistics is not None
        alone = open_recording(split)
        assert alone.config_yaml == recording.config_yaml and 'd.eds' in alone.files
        total += sum(1 for _ in alone.frames())
    assert total == len(sent)


def test_hand_encoded_frame_equals_typestore_serialization(tmp_path: Path) -> None:
    store = typestore()
    msg = frames(3)[2]
    bag = tmp_path / 'one'
    with BagWriter(bag) as writer:
        writer.write_frame(msg, 'can7')
    with AnyReader([bag], default_typestore=store) as reader:
        (connection, stamp, raw), = list(reader.messages())
        decoded = reader.deserialize(raw, connection.msgtype)
    assert connection.msgtype == FRAME_TYPE and connection.topic == '/can/frames'
    assert stamp == round(msg.timestamp * 1e9)
    types = store.types
    expected = types[FRAME_TYPE](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=stamp // 10**9, nanosec=stamp % 10**9),
            frame_id='can7'),
        id=msg.arbitration_id, is_extended=msg.is_extended_id, is_rtr=msg.is_remote_frame, is_error=False,
        dlc=msg.dlc, data=np.frombuffer(bytes(msg.data), dtype=np.uint8), direction=1)
    assert bytes(store.serialize_cdr(expected, FRAME_TYPE)) == bytes(raw)
    assert decoded.header.frame_id == 'can7'


def test_split_by_time(tmp_path: Path) -> None:
    bag = tmp_path / 'timed'
    with BagWriter(bag, split_seconds=1.0) as writer:
        for msg in frames(3500):  # 3.5 s at 1 ms
            writer.write_frame(msg)
    assert len(list(bag.glob('*.mcap'))) == 4


def test_writer_refuses_existing_path_and_unknown_type(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='exists already'):
        BagWriter(tmp_path)
    writer = BagWriter(tmp_path / 'b')
    with pytest.raises(BagError, match='unknown message type'):
        writer.write('/x', 'no_pkg/msg/Nothing', 1, b'\x00\x01\x00\x00')


def test_open_recording_errors(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='no such file'):
        open_recording(tmp_path / 'missing.trc')
    (tmp_path / 'x.xyz').write_text('hello')
    with pytest.raises(BagError, match="unknown format '.xyz'"):
        open_recording(tmp_path / 'x.xyz')
    empty = tmp_path / 'dir'
    empty.mkdir()
    with pytest.raises(BagError, match='no metadata.yaml'):
        open_recording(empty)
    (tmp_path / 'bad.mcap').write_bytes(b'\x89MCAP0\r\nnot really')
    with pytest.raises(BagError, match='bad.mcap'):
        open_recording(tmp_path / 'bad.mcap')
