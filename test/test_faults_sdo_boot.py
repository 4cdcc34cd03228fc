"""Fault catalogue, SDO: an abort or a timeout in the middle of a node's boot, and a
drive that reboots (power cycle) while its joint streams. The message names node, step
and cause; the other nodes boot and move regardless; the rebooted joint is configured
again and not re-enabled."""
from __future__ import annotations

import dataclasses

import pytest

from bustools import config_from, demo_data, eventually
from drive_bridge.cia402.statemachine import State
from drive_bridge.master.events import EventKind
from drive_bridge.master.master import Master
from drive_bridge.sim import SimulatedBus
from faulttools import Events, moving, stream_ramp


def quick_retry_config():
    config = config_from(demo_data())
    nodes = tuple(dataclasses.replace(n, timeouts=dataclasses.replace(
        n.timeouts, boot_retries=0, boot_retry_interval=0.5)) for n in config.nodes)
    return dataclasses.replace(config, nodes=nodes)


@pytest.mark.parametrize('fault, expected', [
    ('abort', 'node 4 (lift_drive) boot step "heartbeat producer": node 4 object 0x1017:00: SDO abort '
              '0x08000020: data cannot be transferred or stored to the application'),
    ('timeout', 'node 4 (lift_drive) boot step "RPDO1 mapping": SdoCommunicationError: No SDO response'),
])
def test_an_sdo_fault_mid_boot_names_the_step_and_the_others_boot(fault: str, expected: str) -> None:
    config = quick_retry_config()
    sim = SimulatedBus(config)
    drive = sim.drive(4)
    if fault == 'abort':
        drive.abort_sdo_on(0x1017, 0, 0x08000020)
    else:
        drive.set_sdo_delay(2.0)  # every answer later than the 300 ms SDO timeout
    sim.start()
    master = Master(config)
    events = Events(master)
    try:
        master.start()
        failed = events.wait(EventKind.BOOT_FAILED, 8.0)
        assert failed.node_id == 4 and expected in failed.message, failed.message
        master.wait_until_operational(5.0, ['base_drive', 'arm_drive'])
        stream_ramp(master, 'base_joint', 0.02)
        assert moving(master, 'base_joint')
        assert not master.nodes['lift_drive'].available
        # the cause goes away: the retry boots it
        drive.abort_sdo_on(0x1017, 0, None)
        drive.set_sdo_delay(0.0)
        master.wait_until_operational(8.0)
        assert master.axes['lift_joint'].snapshot().state is not State.OPERATION_ENABLED
    finally:
        master.stop()
        sim.stop()


def test_a_drive_power_cycled_mid_motion_is_configured_again_and_only_its_joint_stops() -> None:
    from bustools import running
    with running(config_from(demo_data())) as (master, sim):
        events = Events(master)
        for joint in ('base_joint', 'lift_joint'):
            stream_ramp(master, joint, 0.02)
        drive = sim.drive(4)
        drive.power_off()
        drive.power_on()
        noticed = events.wait(EventKind.UNEXPECTED_BOOT, 3.0)
        assert noticed.message == ('node 4 (lift_drive) sent a boot-up message while operational '
                                   '(reset or power cycle); configuring it again')
        assert moving(master, 'base_joint')
        master.wait_until_operational(5.0)
        lift = master.axes['lift_joint'].snapshot()
        assert lift.state is not State.OPERATION_ENABLED and 'enable the axis to move it' in lift.message
        assert not moving(master, 'lift_joint', 0.2)
        eventually(lambda: drive.axis(0).state is not State.OPERATION_ENABLED, 1.0, 'the drive disabled')


def test_a_permanent_refusal_is_found_without_retries_and_a_new_boot_up_is_booted_again() -> None:
    config = quick_retry_config()  # boot_retries 0: one attempt per round
    sim = SimulatedBus(config)
    drive = sim.drive(4)
    drive.abort_sdo_on(0x1017, 0, 0x06090030)  # value range exceeded: retrying cannot help
    sim.start()
    master = Master(config)
    events = Events(master)
    try:
        master.start()
        eventually(lambda: any('permanent' in e.message for e in events.of(EventKind.BOOT_FAILED)), 8.0,
                   'the refusal found permanent across rounds')
        drive.abort_sdo_on(0x1017, 0, None)  # the drive is replaced: it boots up again
        drive.power_off()
        drive.power_on()
        master.wait_until_operational(8.0)
    finally:
        master.stop()
        sim.stop()
