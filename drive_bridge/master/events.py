"""Events the master reports about the bus (boot, heartbeat, errors), for logs and diagnostics."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum


class EventKind(str, Enum):
    CONFIGURED = 'configured'  # what a node's PDO map or an axis' mode came out as, and why
    BOOTED = 'booted'
    BOOT_FAILED = 'boot_failed'
    HEARTBEAT_LOST = 'heartbeat_lost'
    HEARTBEAT_BACK = 'heartbeat_back'
    GUARDING_LOST = 'guarding_lost'
    GUARDING_ERROR = 'guarding_error'
    GUARDING_BACK = 'guarding_back'
    UNEXPECTED_BOOT = 'unexpected_boot'
    PDO_STALE = 'pdo_stale'
    PDO_FRESH = 'pdo_fresh'
    BUS_ERROR = 'bus_error'
    BUS_BACK = 'bus_back'
    UNKNOWN_FRAMES = 'unknown_frames'
    RUN_ON_STOP = 'run_on_stop'  # a drive that runs on by itself is being stopped after a liveness loss
    SETPOINT_REFUSED = 'setpoint_refused'  # the cycle's last check held an axis (joint in ``joint``)
    ERROR = 'error'


class Level(str, Enum):
    INFO = 'info'
    WARN = 'warn'
    ERROR = 'error'


@dataclass(frozen=True)
class BusEvent:
    kind: EventKind
    level: Level
    message: str
    node_id: int = 0
    node_name: str = ''
    timestamp: float = field(default_factory=time.time)
    joint: str = ''  # the joint it concerns, where one

    def __str__(self) -> str:
        return self.message
