"""Helpers for tests that run the core master against simulated drives on a virtual bus."""
from __future__ import annotations

import copy
import itertools
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml

from drive_bridge.config import parse_bus_config
from drive_bridge.master.master import Master
from drive_bridge.model import BusConfig
from drive_bridge.sim import SimulatedBus
from waittools import wait_for as eventually  # noqa: F401  (one polling helper for all tests)

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / 'config' / 'demo.yaml'
_channels = itertools.count()


def unique_channel(prefix: str = 'test') -> str:
    """A virtual channel no other test in this process uses."""
    return f'{prefix}-{os.getpid()}-{next(_channels)}'


def demo_data(channel: str | None = None) -> dict[str, Any]:
    """The shipped demo configuration as data, on a channel of its own."""
    data = yaml.safe_load(DEMO.read_text())
    data['bus']['channel'] = channel or unique_channel()
    return data


def config_from(data: dict[str, Any], source: str = 'test config') -> BusConfig:
    return parse_bus_config(copy.deepcopy(data), source, DEMO.parent)


@contextmanager
def running(config: BusConfig, boot_timeout: float = 10.0, wait: bool = True) -> Iterator[tuple[Master, SimulatedBus]]:
    """Simulated drives plus a started master; both stopped afterwards."""
    sim = SimulatedBus(config).start()
    master = Master(config)
    try:
        master.start()
        if wait:
            master.wait_until_operational(boot_timeout)
        yield master, sim
    finally:
        master.stop()
        sim.stop()
