"""``drive-bridge sim CONFIG``: the simulated drives of a bus configuration on a CAN interface,
in a process of their own, until Ctrl-C or SIGTERM.

The drives are the ones the bridge simulates in-process when ``simulation.enabled`` is set
(with the ``simulation.nodes`` options), here on any python-can interface: the package's
``local`` bus between processes of this machine, or ``socketcan``/``vcan0`` where the
machine has it. The bridge then runs with the same bus and the simulation disabled.
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from drive_bridge.cli.errors import CommandError
from drive_bridge.stopsignals import stop_on_signals


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('config', type=Path, help='bus configuration YAML (its nodes are simulated)')
    parser.add_argument('--interface', help="python-can interface (default: the config's bus.interface), "
                                            "e.g. local (between processes here) or socketcan")
    parser.add_argument('--channel', help="channel (default: the config's bus.channel), e.g. a name or vcan0")


def run(args: argparse.Namespace) -> int:
    from drive_bridge.config import load_bus_config
    from drive_bridge.master.bus import open_bus
    from drive_bridge.sim import SimulatedBus

    config = load_bus_config(args.config)
    bus_cfg = dataclasses.replace(config.bus, interface=args.interface or config.bus.interface,
                                  channel=args.channel or config.bus.channel)
    config = dataclasses.replace(config, bus=bus_cfg)
    if not config.nodes:
        raise CommandError(f'{args.config}: the configuration has no nodes to simulate')
    try:
        bus = open_bus(bus_cfg.interface, bus_cfg.channel, bus_cfg.bitrate, **dict(bus_cfg.options))
    except Exception as exc:  # python-can's CanError and the interfaces' own errors
        raise CommandError(str(exc)) from None
    try:
        simulation = SimulatedBus(config, bus=bus)
    except (KeyError, ValueError) as exc:  # a family without a simulator, options of no node
        bus.shutdown()
        raise CommandError(f'{args.config}: {exc}') from None
    with stop_on_signals() as stop:  # the signal ends the wait; the drives stop from ordinary code
        simulation.start()
        try:
            where = f'{bus_cfg.interface}:{bus_cfg.channel}'
            for node in config.nodes:
                joints = ', '.join(axis.joint for axis in node.axes) or 'no axes'
                print(f'simulating {node.name} (node {node.node_id}, {node.family}; {joints}) on {where}',
                      flush=True)
            while not stop.wait(0.5):
                pass
        finally:
            simulation.stop()
    return 0
