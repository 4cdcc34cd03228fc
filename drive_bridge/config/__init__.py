"""Bus configuration: YAML file -> typed, validated, frozen :class:`BusConfig`.

The typed model lives in :mod:`drive_bridge.model` (below the families, which build
default PDO maps from it); this package reads YAML and asks the families for defaults.
"""
from __future__ import annotations

from drive_bridge.config.eds import load_object_dictionary
from drive_bridge.config.errors import ConfigError, Issue
from drive_bridge.config.loader import load_bus_config, load_bus_config_text, parse_bus_config

__all__ = ['ConfigError', 'Issue', 'load_bus_config', 'load_bus_config_text', 'load_object_dictionary',
           'parse_bus_config']
