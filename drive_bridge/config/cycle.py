"""The SYNC cycle settings checked together: the synchronous window (0x1007) must fit in the
SYNC period, and the bus must carry the cyclic traffic at that period. The loader checks the
file's values; :func:`with_sync_period` checks a period given from elsewhere (the node's ROS
parameter ``sync_period``) the same way, so an override cannot bypass the budget."""
from __future__ import annotations

import dataclasses

from drive_bridge.config.busbudget import budget_verdict, bus_budget
from drive_bridge.config.errors import ConfigError, Issue
from drive_bridge.model import BusConfig, MasterConfig


def sync_window_problem(master: MasterConfig, period_key: str = 'master.sync_period') -> str | None:
    """Why ``master.sync_window`` cannot be used with this SYNC period (None: it can).
    CiA 301 §7.5.2.9: the window opens at SYNC, so it must end before the next SYNC."""
    window = master.sync_window
    if window is None:
        return None
    if not master.sends_sync:
        return (f'{window * 1e6:.0f} µs needs a SYNC period ({period_key} is 0: no SYNC); '
                'remove master.sync_window or give a SYNC period')
    if not 0 < window < master.sync_period:
        return (f'{window * 1e6:.0f} µs must be > 0 and shorter than the SYNC period '
                f'({period_key} = {master.sync_period * 1e6:.0f} µs)')
    return None


def with_sync_period(config: BusConfig, period: float, source: str = 'parameter sync_period') -> BusConfig:
    """``config`` at SYNC period ``period`` (s), checked as the loader checks the file's: a
    sync_window that no longer fits and a load over 100 % (unless bus.allow_overload) raise
    ConfigError naming ``source``; a load over 70 % adds the warning to ``config.warnings``."""
    master = dataclasses.replace(config.master, sync_period=period)
    nodes = config.nodes
    errors: list[Issue] = []
    period_key = source.removeprefix('parameter ')
    problem = sync_window_problem(master, period_key=period_key)
    if problem:
        errors.append(Issue(source, 'master.sync_window', problem))
    warning, error = budget_verdict(bus_budget(config.bus.bitrate, master, nodes), config.allow_overload,
                                    period_key=period_key)
    if error:
        errors.append(Issue(source, '', f'{period * 1e6:.0f} µs: {error}'))
    if errors:
        raise ConfigError(errors)
    # the file's budget verdict was for its own period: replaced by the one for this period
    file_warning, _ = budget_verdict(bus_budget(config.bus.bitrate, config.master, nodes), config.allow_overload)
    warnings = tuple(w for w in config.warnings if not (file_warning and w.endswith(f': bus: {file_warning}')))
    if warning:
        warnings += (str(Issue(source, '', f'{period * 1e6:.0f} µs: {warning}')),)
    return dataclasses.replace(config, master=master, warnings=warnings)
