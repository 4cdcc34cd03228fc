"""``drive-bridge scan``: find the nodes on a live bus, name them, write a starter bus config."""
from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path

import canopen

from drive_bridge.bag.edsmatch import EdsFile, eds_paths, matching, read_eds_files
from drive_bridge.bag.errors import ScanError
from drive_bridge.bag.scan import FoundNode, parse_node_ids, scan
from drive_bridge.bag.starter import starter_config


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--interface', required=True,
                        help='python-can interface (socketcan, pcan, virtual...; no default: the bus is real)')
    parser.add_argument('--channel', required=True, help='python-can channel')
    parser.add_argument('--bitrate', type=int, help='bit/s (default: the interface\'s)')
    parser.add_argument('--nodes', default='1-127', help='node ids to ask, e.g. 1-127 or 2,3,10-12')
    parser.add_argument('--timeout', type=float, default=0.2, help='s to wait for each SDO answer (default 0.2)')
    parser.add_argument('--eds', type=Path, action='append', default=[], metavar='PATH',
                        help="an EDS/DCF file or a directory of them (repeatable): the starter config's dcf "
                             "names the one whose identity is the node's")
    parser.add_argument('-o', '--output', type=Path, help='write a starter bus config here')


def run(args: argparse.Namespace) -> int:
    ids = parse_node_ids(args.nodes)
    if not args.timeout > 0:
        raise ScanError(f'--timeout {args.timeout}: must be > 0')
    if args.output is not None and args.output.exists():
        raise ScanError(f'{args.output}: exists already; not overwritten')
    eds_files, notes = read_eds_files(eds_paths(args.eds))
    for note in notes:
        print(note)
    network = canopen.Network()
    kwargs = {'bitrate': args.bitrate} if args.bitrate else {}
    try:
        network.connect(interface=args.interface, channel=args.channel, **kwargs)
    except Exception as exc:
        raise ScanError(f'cannot open CAN bus interface={args.interface!r} channel={args.channel!r}: {exc}') from exc
    try:
        found = scan(network, ids, args.timeout, on_node=lambda node: print(node.describe()))
    finally:
        network.disconnect()
    print(f'{len(found)} node(s) answered of {len(ids)} asked')
    dcf = {node.node_id: _dcf_texts(node, eds_files, args.output) for node in found} if eds_files else {}
    if args.output is not None:
        args.output.write_text(starter_config(found, args.interface, args.channel, args.bitrate, dcf),
                               encoding='utf-8')
        print(f'starter config: {args.output}')
    return 0 if found else 1


def _dcf_texts(node: FoundNode, files: Sequence[EdsFile], output: Path | None) -> list[str]:
    """The EDS files of ``files`` that fit the node, as the starter config names them: relative
    to the config's folder where given relative, else as given."""
    texts = []
    for match in matching(node.identity, files):
        path = match.path
        if not path.is_absolute() and output is not None:
            path = Path(os.path.relpath(path.resolve(), output.resolve().parent))
        texts.append(path.as_posix())
    if texts:
        print(f'node {node.node_id:3d}: EDS {texts[0]}' + (f' (also {", ".join(texts[1:])})' if texts[1:] else ''))
    return texts
