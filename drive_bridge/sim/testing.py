"""Test-side helpers for talking to simulated devices over the bus like a master.

Used by the simulator's own tests and usable by the master's: a frame log on a
canopen Network, a polling wait, a paced SYNC loop, unique virtual channel names,
and NodeConfigs for the shipped generic EDS files.
"""
from __future__ import annotations

import itertools
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can
import canopen

from drive_bridge.model import NodeConfig
from drive_bridge.resources import family_data
from drive_bridge.sim.registry import simulator_for
from drive_bridge.sim.slave import NOTIFIER_CYCLE, SimulatedSlave

GENERIC402_EDS = family_data('generic402', 'generic402.eds')
GENERIC402_2AXIS_EDS = family_data('generic402', 'generic402_2axis.eds')
AKD_EDS = family_data('akd', 'akd.eds')
SYNC_COB_ID = 0x080

_channels = itertools.count()


def unique_channel(prefix: str = 'simtest') -> str:
    """A virtual channel name nobody else in this process uses."""
    return f'{prefix}-{os.getpid()}-{next(_channels)}'


def node_config(node_id: int, name: str | None = None, eds: Path = GENERIC402_EDS,
                family: str = 'generic_402') -> NodeConfig:
    """A NodeConfig for a shipped EDS (the od imported for ``node_id``)."""
    return NodeConfig(name or f'node{node_id}', node_id, family, canopen.import_od(str(eds), node_id), eds)


@dataclass(frozen=True)
class Frame:
    timestamp: float  # time.monotonic() when the test side received it
    cob_id: int
    data: bytes


class FrameLog:
    """Every frame a Network receives, in order (attach before the traffic starts)."""

    def __init__(self, network: canopen.Network) -> None:
        self._frames: list[Frame] = []
        self._lock = threading.Lock()
        if network.notifier is None:
            raise RuntimeError('FrameLog: connect the Network first')
        network.notifier.add_listener(self._on_message)

    def _on_message(self, msg: can.Message) -> None:
        frame = Frame(time.monotonic(), msg.arbitration_id, bytes(msg.data))
        with self._lock:
            self._frames.append(frame)

    def frames(self, cob_id: int | None = None, since: float = 0.0) -> list[Frame]:
        with self._lock:
            return [f for f in self._frames if (cob_id is None or f.cob_id == cob_id) and f.timestamp >= since]

    def clear(self) -> None:
        with self._lock:
            self._frames.clear()

    def wait_for(self, cob_id: int, count: int = 1, timeout: float = 1.0, since: float = 0.0) -> list[Frame]:
        """At least ``count`` frames on ``cob_id`` (received after ``since``); AssertionError on timeout."""
        wait_until(lambda: len(self.frames(cob_id, since)) >= count, timeout,
                   f'{count} frame(s) on 0x{cob_id:03X}')
        return self.frames(cob_id, since)


def wait_until(predicate: Callable[[], bool], timeout: float = 1.0, what: str = 'condition',
               poll: float = 0.002) -> None:
    """Poll ``predicate`` until true; AssertionError naming ``what`` after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while True:
        if predicate():
            return
        if time.monotonic() > deadline:
            raise AssertionError(f'timed out after {timeout} s waiting for {what}')
        time.sleep(poll)


class SyncLoop:
    """A master cycle in the calling thread: ``before(i)`` (send RPDOs), SYNC, ``after(i)``,
    paced by absolute deadlines (late cycles are not made up with bursts)."""

    def __init__(self, network: canopen.Network, period: float) -> None:
        self.network = network
        self.period = period

    def sync(self) -> None:
        self.network.send_message(SYNC_COB_ID, b'')

    def _pace(self, deadline: float) -> float:
        """Sleep to the next absolute deadline; a late cycle restarts the grid (no burst)."""
        deadline += self.period
        delay = deadline - time.monotonic()
        if delay > 0:
            time.sleep(delay)
            return deadline
        return time.monotonic()

    def run(self, cycles: int, before: Callable[[int], None] | None = None,
            after: Callable[[int], None] | None = None) -> None:
        deadline = time.monotonic()
        for i in range(cycles):
            if before is not None:
                before(i)
            self.sync()
            if after is not None:
                after(i)
            deadline = self._pace(deadline)

    def run_until(self, predicate: Callable[[], bool], timeout: float,
                  before: Callable[[int], None] | None = None, what: str = 'condition') -> int:
        """Cycle until ``predicate()``; returns the cycles run; AssertionError on timeout."""
        deadline = time.monotonic()
        end = deadline + timeout
        i = 0
        while not predicate():
            if time.monotonic() > end:
                raise AssertionError(f'timed out after {timeout} s of SYNC cycles waiting for {what}')
            if before is not None:
                before(i)
            self.sync()
            i += 1
            deadline = self._pace(deadline)
        return i


class SimBench:
    """A test-side master (canopen Network + FrameLog) on a fresh virtual channel, and
    simulated nodes on it, each with its own Network (as a separate device would be).
    ``close()`` powers everything off and disconnects: no thread survives."""

    def __init__(self, channel: str | None = None) -> None:
        self.channel = channel or unique_channel()
        self.master = canopen.Network()
        self.master.NOTIFIER_CYCLE = NOTIFIER_CYCLE
        self.master.connect(interface='virtual', channel=self.channel, receive_own_messages=False)
        self.log = FrameLog(self.master)
        self.sims: list[SimulatedSlave] = []

    def add_drive(self, node_id: int = 5, *, eds: Path = GENERIC402_EDS, family: str = 'generic_402',
                  options: dict[str, Any] | None = None, power_on: bool = True,
                  cls: type[SimulatedSlave] | None = None) -> tuple[Any, canopen.RemoteNode]:
        """(simulator, RemoteNode) for a node on this channel; waits for its boot-up when powering on."""
        sim = (cls or simulator_for(family))(node_config(node_id, eds=eds, family=family), options=options)
        sim.connect(self.channel)
        self.sims.append(sim)
        remote = self.master.add_node(node_id, canopen.import_od(str(eds), node_id))
        if power_on:
            start = time.monotonic()
            sim.power_on()
            self.log.wait_for(0x700 + node_id, since=start)
        return sim, remote

    def send(self, cob_id: int, data: bytes) -> None:
        self.master.send_message(cob_id, data)

    def nmt(self, command: int, node_id: int = 0) -> None:
        """Raw NMT command (0x01 start, 0x02 stop, 0x80 pre-op, 0x81 reset node, 0x82 reset comm)."""
        self.master.send_message(0x000, bytes([command, node_id]))

    def close(self) -> None:
        for sim in self.sims:
            sim.close()
        self.sims.clear()
        self.master.disconnect()

    def __enter__(self) -> SimBench:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
