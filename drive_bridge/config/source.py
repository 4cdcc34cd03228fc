"""Where a bus configuration comes from, with the node's start-time overrides: what the node
process reads for itself and hands to its bus process, so both load the same configuration."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from drive_bridge.config.cycle import with_sync_period
from drive_bridge.config.errors import ConfigError
from drive_bridge.config.loader import load_bus_config, load_bus_config_text
from drive_bridge.model import BusConfig


@dataclass(frozen=True)
class ConfigSource:
    """A YAML file (``path``) or YAML text (``text``, relative paths from ``base_dir``), and the
    overrides: ``sync_period`` > 0 replaces master.sync_period (checked as the file's own
    period is: window and bus budget); ``simulate`` turns simulated drives on (virtual bus only)."""

    path: str = ''
    text: str = ''
    base_dir: str = ''
    text_name: str = 'parameter config_yaml'
    sync_period: float = 0.0
    simulate: bool = False


def load(source: ConfigSource) -> BusConfig:
    """The configuration; ConfigError lists every problem, ValueError says what is missing."""
    if source.text:
        config = load_bus_config_text(source.text, source.text_name, source.base_dir or Path.cwd())
    elif source.path:
        config = load_bus_config(Path(source.path))
    else:
        raise ValueError('no bus configuration: set the parameter config (a YAML file) or config_yaml')
    if source.sync_period > 0:
        config = with_sync_period(config, source.sync_period)
    if source.simulate and not config.simulation.enabled:
        if config.bus.interface != 'virtual':
            raise ConfigError.single(source.text_name if source.text else source.path, 'simulation',
                                     'parameter simulate needs the virtual CAN interface; the configuration '
                                     f'uses {config.bus.interface!r}')
        config = dataclasses.replace(config, simulation=dataclasses.replace(config.simulation, enabled=True))
    return config
