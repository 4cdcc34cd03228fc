"""``drive-bridge replay``: a bag or trace onto a CAN bus with its timing, or offline through
the bridge's decoders into a bag of decoded topics."""
from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import can
from tqdm import tqdm  # type: ignore[import-untyped]

from drive_bridge.bag.errors import BagError
from drive_bridge.bag.source import Recording, open_recording
from drive_bridge.cli.command import add_progress_option


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('input', type=Path, metavar='INPUT', help='rosbag2 bag (directory or .mcap) or trace')
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument('--onto', action='store_true', help='send the frames onto a bus with their recorded timing')
    what.add_argument('--decode', action='store_true',
                      help='decode offline (joint states, axis states, EMCY, bus events) into the bag -o')
    bus = parser.add_argument_group('--onto')
    bus.add_argument('--interface', help='python-can interface (socketcan, pcan, virtual...; default: --config\'s)')
    bus.add_argument('--channel', help='python-can channel (default: --config\'s)')
    bus.add_argument('--bitrate', type=int, help='bit/s, for interfaces that set it (default: --config\'s)')
    bus.add_argument('--node', type=int, nargs='+', action='extend', default=[], metavar='N',
                     help='only frames from/to these nodes (--node 2 3 or --node 2 --node 3; their PDOs, SDOs, '
                          'EMCY, heartbeat, NMT commands to them; not SYNC)')
    bus.add_argument('--direction', choices=('rx', 'tx'),
                     help='rx: frames the recording master received (the nodes); tx: frames it sent')
    bus.add_argument('--speed', type=float, default=1.0, help='time factor (2: twice as fast)')
    dec = parser.add_argument_group('--decode')
    parser.add_argument('--config', type=Path, help='bus config: --decode decodes with it (default: the one stored '
                        'in the bag), --onto takes the bus from it')
    dec.add_argument('-o', '--output', type=Path, help='bag to write (must not exist)')
    dec.add_argument('--namespace', default='/drive_bridge', help="the bridge node's topics (default /drive_bridge)")
    add_progress_option(parser, '--quiet')


def run(args: argparse.Namespace) -> int:
    recording = open_recording(args.input)
    return _onto(args, recording) if args.onto else _decode(args, recording)


def _onto(args: argparse.Namespace, recording: Recording) -> int:
    from drive_bridge.bag.replay_bus import frame_filter, replay_onto

    interface, channel, bitrate = args.interface, args.channel, args.bitrate
    if args.config is not None:  # the bus of the config, unless given
        from drive_bridge.config.loader import load_bus_config
        config = load_bus_config(args.config)
        interface = interface or config.bus.interface
        channel = channel if channel is not None else config.bus.channel
        bitrate = bitrate if bitrate is not None else config.bus.bitrate
    if not interface or channel is None:  # no default: 'virtual' would replay into this process only
        raise BagError('replay --onto: give the bus with --interface and --channel (or --config with a bus section)')
    keep = frame_filter(args.node, args.direction)
    kwargs = {'bitrate': bitrate} if bitrate else {}
    try:
        bus = can.Bus(interface=interface, channel=channel, **kwargs)
    except Exception as exc:
        raise BagError(f'cannot open CAN bus interface={interface!r} channel={channel!r}: {exc}') from exc
    try:
        with tqdm(unit=' frames', disable=args.no_progress, desc='replay') as bar:
            stats = replay_onto(recording.frames(), bus, speed=args.speed, keep=keep, on_frame=bar.update)
    finally:
        bus.shutdown()
    print('\n'.join(stats.lines()))
    return 0


def _decode(args: argparse.Namespace, recording: Recording) -> int:
    from drive_bridge.bag.decoded_msgs import Topics
    from drive_bridge.bag.offline import decode_into, recording_config
    from drive_bridge.bag.recorder import config_files
    from drive_bridge.bag.writer import BagWriter

    if args.output is None:
        raise BagError('replay --decode: give the bag to write with -o OUTPUT')
    config = recording_config(recording, args.config)
    config_yaml = args.config.read_text(encoding='utf-8') if args.config is not None else recording.config_yaml
    files = config_files(config) if args.config is not None else recording.files  # the config's EDS with it
    writer = BagWriter(args.output, config_yaml=config_yaml, files=files)
    try:
        with tqdm(unit=' frames', disable=args.no_progress, desc='decode') as bar:
            stats = decode_into(recording.frames(), config, writer, Topics(args.namespace.rstrip('/')),
                                on_frame=bar.update)
    except BaseException:
        writer.close()
        shutil.rmtree(args.output, ignore_errors=True)  # no half-decoded bag left behind
        raise
    writer.close()
    print('\n'.join([f'{args.output}:', *stats.lines()]))
    return 0
