"""``master.sync_producer: kernel``: refused on an interface without a kernel timer, and the
bridge's side of it (SYNC from the interface's periodic task, the cycle run from the looped-back
frame) through a test double. Real SocketCAN is not available on these machines: the kernel's
BCM itself is untested here."""
from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

import can
import pytest
import yaml
from can.broadcastmanager import CyclicSendTaskABC
from can.interfaces.virtual import VirtualBus
from rclpy.parameter import Parameter

from bustools import config_from, demo_data, eventually
from drive_bridge.config.errors import ConfigError
from drive_bridge.joint import Setpoint
from drive_bridge.master.kernelsync import sends_periodic_in_kernel
from drive_bridge.master.master import Master
from drive_bridge.master.sync import SYNC_COB_ID
from drive_bridge.model import BusConfig
from drive_bridge.ros.errors import StartupError
from drive_bridge.ros.node import BusNode
from drive_bridge.sim import SimulatedBus
from drive_bridge.sim.faults import FaultyBus
from rostools import RosHarness
from timingtools import BUSY_SLACK

REFUSAL = (r"master\.sync_producer: 'kernel' needs an interface whose periodic frames the kernel sends .*"
           r"interface 'virtual' .*use sync_producer: bridge")


class KernelTimerBus(can.BusABC):
    """A stand-in for a SocketCAN bus: a RAW socket (a virtual bus) plus a BCM socket (a second
    virtual bus on the channel) whose periodic frames the channel delivers to the RAW bus as
    received frames, as the kernel loops BCM frames back. Its timer is still a Python thread:
    this checks the bridge's path, not the kernel's timing."""

    sends_periodic_in_kernel = True  # the declaration sends_periodic_in_kernel() honours

    def __init__(self, channel: str) -> None:
        self._raw = can.Bus(interface='virtual', channel=channel)
        self._bcm = can.Bus(interface='virtual', channel=channel)
        super().__init__(channel=channel)
        self.channel_info = f'kernel-timer double on {channel}'

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self._raw.send(msg, timeout)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        return self._raw.recv(timeout), False

    def _send_periodic_internal(self, msgs: Sequence[can.Message] | can.Message, period: float,
                                duration: float | None = None, autostart: bool = True,
                                modifier_callback: Callable[[can.Message], None] | None = None,
                                ) -> CyclicSendTaskABC:
        return self._bcm.send_periodic(msgs, period, duration, autostart=autostart)

    def shutdown(self) -> None:
        super().shutdown()
        self._bcm.shutdown()
        self._raw.shutdown()


def kernel_config(sync_period_us: int = 4000) -> BusConfig:
    data = demo_data()
    data['master'].update(sync_producer='kernel', sync_period=sync_period_us)
    return config_from(data)


class FaultyKernelTimerBus(FaultyBus):
    """The double behind switchable faults (bus-off), its periodic task still the inner one's."""

    sends_periodic_in_kernel = True

    def _send_periodic_internal(self, msgs: Sequence[can.Message] | can.Message, period: float,
                                duration: float | None = None, autostart: bool = True,
                                modifier_callback: Callable[[can.Message], None] | None = None,
                                ) -> CyclicSendTaskABC:
        return self._inner.send_periodic(msgs, period, duration, autostart=autostart)


@contextmanager
def kernel_master(config: BusConfig, faulty: bool = False) -> Iterator[tuple[Master, SimulatedBus, can.BusABC]]:
    sim = SimulatedBus(config).start()
    bus: can.BusABC = KernelTimerBus(str(config.bus.channel))
    if faulty:
        bus = FaultyKernelTimerBus(bus)
    master = Master(config, bus=bus)
    try:
        master.start()
        master.wait_until_operational(10.0)
        yield master, sim, bus
    finally:
        master.stop()
        sim.stop()


class OwnTimerBus(VirtualBus):
    """An interface with a periodic task of its own (say, in adapter firmware), declaring nothing."""

    def _send_periodic_internal(self, *args: object, **kwargs: object) -> CyclicSendTaskABC:
        return super()._send_periodic_internal(*args, **kwargs)  # type: ignore[arg-type]


def test_the_capability_is_decided_by_the_interface() -> None:
    from can.interfaces.socketcan import SocketcanBus
    virtual = can.Bus(interface='virtual', channel='kernel-capability')
    double = KernelTimerBus('kernel-capability')
    try:
        assert not sends_periodic_in_kernel(virtual)  # BusABC's thread task
        assert sends_periodic_in_kernel(double)  # declared
    finally:
        virtual.shutdown()
        double.shutdown()
    assert sends_periodic_in_kernel(SocketcanBus)  # the BCM (the class only: no SocketCAN here)
    assert not sends_periodic_in_kernel(OwnTimerBus)  # its frames need not come back to the host


def test_kernel_sync_on_an_interface_without_a_kernel_timer_is_refused_at_start() -> None:
    master = Master(kernel_config())
    before = threading.active_count()
    started = time.monotonic()
    with pytest.raises(ConfigError, match=REFUSAL):
        master.start()
    assert time.monotonic() - started < BUSY_SLACK  # refused before anything waits
    assert not master.started and master.kernel_sync is None
    assert threading.active_count() == before  # no Notifier, supervisor or boot thread left behind
    master.stop()  # a no-op, no hang


def test_the_bus_node_reports_the_refusal_as_a_startup_error(ros: RosHarness) -> None:
    data = demo_data()
    data['master']['sync_producer'] = 'kernel'
    data['simulation'] = {'enabled': True}
    with pytest.raises(StartupError, match='cannot start bus virtual:.*' + REFUSAL):
        BusNode(context=ros.context, parameter_overrides=[
            Parameter('config_yaml', value=yaml.safe_dump(data, sort_keys=False))])


def test_the_interface_sends_sync_and_the_looped_back_frame_drives_the_cycle() -> None:
    config = kernel_config(sync_period_us=5000)  # not the demo's 4 ms: 0x1006 shows it was written
    with kernel_master(config) as (master, sim, _bus):
        syncs: list[can.Message] = []
        master.add_frame_listener(lambda msg: syncs.append(msg) if msg.arbitration_id == SYNC_COB_ID else None)
        assert master.sync is None and master.kernel_sync is not None and master.kernel_sync.running
        assert master.sdo_read(2, 0x1006, 0)[1] == 5000  # the cycle period written at boot, as for bridge
        axis = master.axes['base_joint']
        axis.enable(timeout=2.0)  # the controlword RPDOs follow the looped-back SYNC
        p0 = axis.commanded_position()
        t0 = time.time()
        axis.set_setpoint_source(lambda t: Setpoint(position=p0 + 0.2 * min(time.time() - t0, 0.5)))
        time.sleep(0.8)
        assert axis.snapshot().position == pytest.approx(p0 + 0.1, abs=2e-3)
        drive = sim.drive(2)
        assert drive.sync_period == pytest.approx(0.005, rel=0.25)
        assert syncs and all(msg.is_rx for msg in syncs)  # tapped as received: not the send path
        assert len(syncs) > 120  # 0.8 s at 5 ms
        master.stop()  # stops the interface's task too
        count = drive.received_sync_count
        time.sleep(0.1)
        assert drive.received_sync_count <= count + 1


def test_the_interface_task_stops_while_the_bus_is_down_and_starts_again_after() -> None:
    with kernel_master(kernel_config(), faulty=True) as (master, sim, bus):
        assert isinstance(bus, FaultyKernelTimerBus) and master.kernel_sync is not None
        drive = sim.drive(2)
        bus.bus_off(True)
        eventually(lambda: master.bus_down, 3.0, 'the bus reported down')
        assert not master.kernel_sync.running
        count = drive.received_sync_count
        time.sleep(0.1)
        assert drive.received_sync_count <= count + 1  # no SYNC on a dead bus
        bus.bus_off(False)
        eventually(lambda: not master.bus_down, 3.0, 'the bus back')
        assert master.kernel_sync.running
        count = drive.received_sync_count
        eventually(lambda: drive.received_sync_count > count + 20, 2.0, 'SYNC again')
        master.wait_until_operational(8.0)
