"""``drive-bridge``: the package's command-line tool, one subcommand per module.

Each subcommand is a module of this package that follows :class:`Subcommand`; adding one is
one line in ``COMMANDS``. Modules are imported when their verb runs, so ``--help`` and a
fast verb do not pay for rclpy, rosbags or canopen.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from typing import cast

from drive_bridge.cli.command import Subcommand
from drive_bridge.errors import DriveBridgeError
from drive_bridge.stopsignals import exit_code, stop_on_signals

# (verb, module under drive_bridge.cli, one-line help): the one place of a verb's name and help
# (here, so that listing the verbs imports nothing).
COMMANDS: tuple[tuple[str, str, str], ...] = (
    ('sim', 'sim', 'host the simulated drives of a bus configuration on a CAN interface (until Ctrl-C)'),
    ('record', 'record', 'record a bus passively (sends nothing: no SYNC, NMT or SDO) into a rosbag2 MCAP bag'),
    ('import', 'importer',
     'convert a CAN trace (trc, asc, blf, candump log, csv, IXXAT MiniMon...) to a rosbag2 MCAP bag'),
    ('recover', 'recover',
     'make a bag whose recorder was killed readable (rebuild the open split, rewrite metadata.yaml)'),
    ('info', 'info', 'show the topics, types, counts, duration and stored files of a bag (or the frames of a trace)'),
    ('replay', 'replay', 'replay a bag or trace onto a CAN bus (--onto) or through the decoders into a bag (--decode)'),
    ('scan', 'scan', 'find the nodes on a live bus (identity, vendor, drive family) and write a starter bus config'),
    ('diagnose', 'diagnose', 'diagnose a bag or CAN trace: findings, timelines, SDO log, plots (HTML, JSON, summary)'),
)

PROG = 'drive-bridge'
DESCRIPTION = ('CANopen drives in ROS 2: simulate a bus, record, import, replay and diagnose '
               'bus traffic. The bus node itself runs as `bridge CONFIG` (or `bridge_managed`).')


def build_parser(verb: str | None = None) -> tuple[argparse.ArgumentParser, dict[str, Subcommand]]:
    """The tool's parser; only the module of ``verb`` (if given) is imported and configured."""
    parser = argparse.ArgumentParser(prog=PROG, description=DESCRIPTION)
    sub = parser.add_subparsers(dest='verb', metavar='COMMAND', required=True)
    loaded: dict[str, Subcommand] = {}
    for name, module_name, help_text in COMMANDS:
        command_parser = sub.add_parser(name, help=help_text, description=help_text)
        if name == verb:
            module = cast(Subcommand, importlib.import_module(f'drive_bridge.cli.{module_name}'))
            module.configure(command_parser)
            loaded[name] = module
    return parser, loaded


def main(argv: list[str] | None = None) -> int:
    """Parse, run the verb, and turn a :class:`DriveBridgeError` into one line on stderr.

    SIGINT and SIGTERM stop a verb whatever the process inherited (:mod:`drive_bridge.stopsignals`):
    one busy in a long call is interrupted, cleans up and exits 130 (SIGINT) or 143 (SIGTERM);
    ``record`` and ``sim``, which run until stopped, take the signal as their normal end (exit 0).
    """
    args_list = sys.argv[1:] if argv is None else argv
    verb = next((a for a in args_list if not a.startswith('-')), None)
    parser, loaded = build_parser(verb)
    args = parser.parse_args(args_list)
    try:
        with stop_on_signals(interrupt=True):
            return loaded[args.verb].run(args)
    except DriveBridgeError as exc:
        print(f'{PROG} {args.verb}: error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(f'{PROG} {args.verb}: stopped by {str(exc) or "SIGINT"}', file=sys.stderr)
        return exit_code(exc)


def console_main() -> None:
    """The ``drive-bridge`` console entry point."""
    raise SystemExit(main())
