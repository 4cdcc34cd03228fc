"""``drive-bridge record``: passive recording of a bus whose master is not the bridge."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drive_bridge.cli.command import add_progress_option
from drive_bridge.stopsignals import exit_code, stop_on_signals


def configure(parser: argparse.ArgumentParser) -> None:
    parser.description = (f'{parser.description}. For machines whose master is a PLC; Ctrl-C or SIGTERM closes '
                          'the bag (exit 0; a second signal stops at once). '
                          'With --config, the bus settings default to the config\'s, and the config and '
                          'its EDS/DCF files are stored in the bag.')
    parser.add_argument('-o', '--output', type=Path, required=True, help='bag directory to create')
    parser.add_argument('--interface', help='python-can interface (socketcan, pcan, virtual...)')
    parser.add_argument('--channel', help='CAN channel (can0, PCAN_USBBUS1, a virtual channel name)')
    parser.add_argument('--bitrate', type=int, help='bit/s, for interfaces that set it')
    parser.add_argument('--config', type=Path, help='bus configuration YAML to take the bus from and store')
    parser.add_argument('--split-size-mb', type=float, default=0.0, help='rotate splits at this size (0: none)')
    parser.add_argument('--split-seconds', type=float, default=0.0, help='rotate splits after this long (0: none)')
    parser.add_argument('--duration', type=float, default=0.0, help='stop after this many seconds (0: Ctrl-C)')
    add_progress_option(parser, '-q', '--quiet')


def run(args: argparse.Namespace) -> int:
    from drive_bridge.bag.errors import BagError
    from drive_bridge.bag.passive import record_passive
    from drive_bridge.bag.recorder import Recorder, RecorderStats, config_files
    from drive_bridge.config import load_bus_config
    from drive_bridge.master.bus import open_bus

    config = load_bus_config(args.config) if args.config is not None else None
    interface = args.interface or (config.bus.interface if config else None)
    channel = args.channel if args.channel is not None else (config.bus.channel if config else None)
    if not interface or channel is None:
        raise BagError('give --interface and --channel (or --config with a bus section)')
    bitrate = args.bitrate if args.bitrate is not None else (config.bus.bitrate if config else None)
    options = dict(config.bus.options) if config else {}
    if args.split_size_mb < 0 or args.split_seconds < 0:
        raise BagError('--split-size-mb and --split-seconds must be >= 0')
    try:
        bus = open_bus(interface, channel, bitrate if interface != 'virtual' else None, **options)
    except Exception as exc:
        raise BagError(str(exc)) from exc
    try:
        recorder = Recorder(args.output, channel=str(channel), split_bytes=round(args.split_size_mb * 1e6) or None,
                            split_seconds=args.split_seconds or None,
                            config_yaml=args.config.read_text(encoding='utf-8') if args.config else None,
                            files=config_files(config) if config else {})

        def report(stats: RecorderStats) -> None:
            print(f'\r{stats.frames} frames, {stats.dropped} dropped, {stats.bytes / 1e6:.1f} MB, '
                  f'split {stats.split}', end='', file=sys.stderr, flush=True)
        print(f'recording {interface}:{channel} to {recorder.path} (passive: sends nothing; Ctrl-C stops)',
              file=sys.stderr)
        interrupted: KeyboardInterrupt | None = None
        with stop_on_signals() as stop:  # the signal ends the loop; the loop closes the bag
            try:
                stats = record_passive(bus, recorder, stop.event, duration=args.duration,
                                       report=None if args.no_progress else report, name=f'{interface}:{channel}')
            except KeyboardInterrupt as exc:  # a second signal: stop at once
                interrupted = exc
                stats = recorder.stop()
    finally:
        bus.shutdown()
    print(('' if args.no_progress else '\n') + stats.summary())
    if interrupted is not None:
        return exit_code(interrupted)
    return 1 if stats.error or stats.dropped else 0
