"""Bus configuration: YAML file -> typed, validated, frozen :class:`BusConfig`.

``load_bus_config`` and friends are imported on first use: ``drive_bridge.families``
imports ``drive_bridge.config.model`` and the loader imports the families, so an
eager import here would be circular.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from drive_bridge.config.eds import load_object_dictionary
from drive_bridge.config.errors import ConfigError, Issue

if TYPE_CHECKING:
    from drive_bridge.config.loader import load_bus_config, load_bus_config_text, parse_bus_config

__all__ = ['ConfigError', 'Issue', 'load_bus_config', 'load_bus_config_text', 'load_object_dictionary',
           'parse_bus_config']

_LAZY = {'load_bus_config', 'load_bus_config_text', 'parse_bus_config'}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module('drive_bridge.config.loader'), name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
