"""Helpers for the fault-catalogue tests: a master on a fault-injecting bus, event waits,
streaming ramps, and counts of the frames the master sends to a node."""
from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import can

from bustools import eventually
from drive_bridge.joint import Setpoint
from drive_bridge.master.events import BusEvent, EventKind
from drive_bridge.master.master import Master
from drive_bridge.model import BusConfig
from drive_bridge.sim import SimulatedBus
from drive_bridge.sim.faults import FaultyBus


@contextmanager
def running_faulty(config: BusConfig, boot_timeout: float = 10.0) -> Iterator[tuple[Master, SimulatedBus, FaultyBus]]:
    """Simulated drives, and a started master whose bus can fail on demand."""
    sim = SimulatedBus(config).start()
    faulty = FaultyBus(can.Bus(interface='virtual', channel=config.bus.channel, receive_own_messages=False))
    master = Master(config, bus=faulty)
    try:
        master.start()
        master.wait_until_operational(boot_timeout)
        yield master, sim, faulty
    finally:
        master.stop()
        sim.stop()


class Events:
    """Every bus event of a master, with waits by kind."""

    def __init__(self, master: Master) -> None:
        self.all: list[BusEvent] = []
        master.add_event_listener(self.all.append)

    def of(self, kind: EventKind) -> list[BusEvent]:
        return [e for e in self.all if e.kind is kind]

    def wait(self, kind: EventKind, timeout: float = 3.0) -> BusEvent:
        return eventually(lambda: next(iter(self.of(kind)), None), timeout, f'a {kind.value} event')


class SentTo:
    """Counts the RPDO frames the master sends to one node (the tap, both directions)."""

    def __init__(self, master: Master, node_id: int) -> None:
        self.cobs = {0x200 + 0x100 * n + node_id for n in range(4)}
        self.count = 0
        self._lock = threading.Lock()
        master.add_frame_listener(self._on_frame)

    def _on_frame(self, msg: can.Message) -> None:
        if not msg.is_rx and msg.arbitration_id in self.cobs:
            with self._lock:
                self.count += 1

    def during(self, seconds: float) -> int:
        before = self.count
        time.sleep(seconds)
        return self.count - before


def stream_ramp(master: Master, joint: str, rate: float) -> None:
    """Enable the joint in CSP and stream a ramp from where it is, one set-point per cycle."""
    axis = master.axes[joint]
    axis.enable(timeout=2.0)
    axis.set_mode('csp')
    p0 = axis.commanded_position()
    t0 = time.time()
    axis.set_setpoint_source(lambda t: Setpoint(position=p0 + rate * (t - t0)))


def moving(master: Master, joint: str, seconds: float = 0.3) -> bool:
    """The joint's reported position changes over ``seconds``."""
    before = master.axes[joint].snapshot().position
    time.sleep(seconds)
    return abs(master.axes[joint].snapshot().position - before) > 1e-4


@contextmanager
def demo_bridge(ros, data: dict | None = None, **parameters: object):
    """The demo bus node (or ``data``'s) on a private local channel, its simulated drives in this
    process (``node.simulation``, bridgetools), every axis enabled (auto_enable); both stopped
    afterwards."""
    from rclpy.parameter import Parameter

    from bridgetools import bridge_with_sim
    from bustools import demo_data
    from drive_bridge.cia402.statemachine import State

    overrides = {'auto_enable': True, **parameters}
    with bridge_with_sim(ros, data or demo_data(), [Parameter(k, value=v) for k, v in overrides.items()]) as node:
        node.master.wait_until_operational(10.0)
        eventually(lambda: all(a.state is State.OPERATION_ENABLED for a in node.master.axes.values()), 10,
                   'every axis enabled')
        yield node
