"""The OPEN drive family at core level: the loader, the family hooks, and the RUN-logic joint
driver against the simulated OPEN drive (SimOpenDrive) on a virtual bus, with every frame
recorded (akdtools.Sniffer). No ROS here (test_opendrive_ros.py does the same through ROS).

The simulator's defaults are the example config's values: n_MAX 3000 rpm, T_nom 10 N·m,
4 pole pairs, f_pwm 8 kHz, speed reference 0x201A, Tab_osc[0] velocity, [1] torque, no
position, alarm reset function 5, array element k at sub-index k + 1. Timing bounds are
generous: CI is a noisy 2-core machine.
"""
from __future__ import annotations

import math
import struct
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import yaml

from akdtools import BusFrame, Sniffer
from bustools import config_from, eventually, running, unique_channel
from drive_bridge.cia301.emcy import Severity
from drive_bridge.config import ConfigError
from drive_bridge.families import get_family
from drive_bridge.families.errors import ParameterError
from drive_bridge.families.opendrive import RunLogicDriver
from drive_bridge.families.opendrive.alarms import alarm_text
from drive_bridge.families.opendrive.parameters import Format
from drive_bridge.joint import DriveState, JointError, Setpoint
from drive_bridge.master.events import EventKind
from drive_bridge.master.master import Master
from drive_bridge.model import BusConfig
from drive_bridge.sim import SimulatedBus
from timingtools import BUSY_SLACK

EXAMPLE = Path(__file__).resolve().parent.parent / 'config' / 'opendrive_example.yaml'
NODE = 1
JOINT = 'spindle_joint'
RPDO1, TPDO1 = 0x200 + NODE, 0x180 + NODE
SDO_RX = 0x600 + NODE
RUN = 1
RESET_BIT = 1 << 5  # alarm_reset_function 5
N_MAX = 3000 * 2 * math.pi / 60  # rad/s
SPEED_UNIT = N_MAX / 16384  # rad/s per unit of 0x201A
TORQUE_UNIT = 10.0 / 4095  # N·m per unit of 0x201C
EXTRA_BIT = 1 << 3  # a fieldbus logic function the bridge does not own, set by a boot SDO


def example(**node: Any) -> dict[str, Any]:
    """The shipped example as data, on a channel of its own, with node keys replaced."""
    data = yaml.safe_load(EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('opendrive')
    data['nodes']['opendrive'].update(node)
    return data


def axis_data(data: dict[str, Any]) -> dict[str, Any]:
    return data['nodes']['opendrive']['axes'][0]


def with_sim(data: dict[str, Any], **options: Any) -> dict[str, Any]:
    data['simulation'] = {'enabled': True, 'nodes': {'opendrive': options}}
    return data


def problems(data: dict[str, Any]) -> list[str]:
    with pytest.raises(ConfigError) as caught:
        config_from(data, 'od.yaml')
    return str(caught.value).splitlines()


@contextmanager
def bridge(data: dict[str, Any], wait: bool = True) -> Iterator[tuple[Master, SimulatedBus, Sniffer, RunLogicDriver]]:
    config: BusConfig = config_from(data)
    sniffer = Sniffer(config.bus.channel)  # type: ignore[arg-type]
    try:
        with running(config, wait=wait) as (master, sim):
            axis = master.axes[JOINT]
            assert isinstance(axis, RunLogicDriver)
            yield master, sim, sniffer, axis
    finally:
        sniffer.close()


def rpdo(frame: BusFrame) -> tuple[int, int, int]:
    """(0x201F, speed reference, torque reference) of an RPDO1 frame."""
    return struct.unpack('<Ihh', frame.data)


def rpdos(sniffer: Sniffer, after: int = 0) -> list[tuple[int, int, int]]:
    return [rpdo(f) for f in sniffer.frames(RPDO1, after)]


def sdo_downloads(sniffer: Sniffer, after: int = 0) -> list[tuple[int, int, bytes]]:
    """(index, subindex, data) of every SDO download request (initiate) to the node."""
    found = []
    for frame in sniffer.frames(SDO_RX, after):
        if frame.data and frame.data[0] & 0xE0 == 0x20:
            index, sub = struct.unpack_from('<HB', frame.data, 1)
            found.append((index, sub, frame.data[4:]))
    return found


def enabled_at(axis: RunLogicDriver, velocity: float | None = None) -> None:
    axis.enable(timeout=3.0)
    assert axis.drive_state is DriveState.ENABLED
    if velocity is not None:
        axis.command(velocity=velocity)


# -- configuration --------------------------------------------------------------------------------
def test_the_example_loads_with_the_family_defaults() -> None:
    config = config_from(example())
    node = config.nodes[0]
    assert node.family == 'opendrive' and node.eds_path is not None and node.eds_path.name == 'opendrive.eds'
    assert (node.guard_time_ms, node.life_time_factor, node.heartbeat_producer_ms) == (100, 3, 0)
    axis = node.axes[0]
    assert axis.mode == 3 and axis.drive['speed_reference'] == 0x201A and axis.drive['array_offset'] == 1
    # the default PDO map: one RPDO (type 1), TPDO1 every SYNC (type 0: this drive's meaning), TPDO2
    (rx,) = node.rpdo
    assert (rx.cob_id, rx.transmission) == (RPDO1, 1)
    assert [(e.index, e.subindex, e.bits) for e in rx.mapping] == [(0x201F, 0, 32), (0x201A, 0, 16), (0x201C, 0, 16)]
    tx1, tx2 = node.tpdo
    assert (tx1.cob_id, tx1.transmission, tx2.transmission) == (TPDO1, 0, 0)
    assert [(e.index, e.subindex, e.bits) for e in tx1.mapping] == [(0x2021, 0, 32), (0x2018, 0, 16),
                                                                    (0x2012, 1, 16)]
    assert [(e.index, e.subindex) for e in tx2.mapping] == [(0x2012, 2)]  # actual torque, element 1 + offset 1


def test_every_unknown_of_the_appendix_is_a_required_drive_setting() -> None:
    data = example()
    axis_data(data)['drive'] = {'actual_torque': {'table': 'tab_osc', 'element': 1}}
    found = problems(data)
    for key in ('n_max_rpm', 'rated_torque', 'pole_pairs', 'pwm_frequency', 'speed_reference', 'actual_velocity',
                'position', 'alarm_reset_function', 'array_offset'):
        assert any(f'drive.{key}: required' in p for p in found), (key, found)
    assert not any('actual_torque' in p for p in found)  # optional
    assert any('does not give it' in p for p in found)


def test_drive_settings_are_checked_each_at_its_key() -> None:
    data = example()
    drive = axis_data(data)['drive']
    drive.update(speed_reference=0x201B, array_offset=2, alarm_reset_function=0, pole_pairs=0, n_max_rpm=-1,
                 actual_velocity={'table': 'tab_x', 'element': 64}, position={'table': 'tab_osc', 'element': 1},
                 bogus=1)
    found = '\n'.join(problems(data))
    assert 'drive.speed_reference: expected 0x201A' in found
    assert 'drive.array_offset: expected 0 or 1, got 2' in found
    assert 'drive.alarm_reset_function: expected a standard logic input function number (0 is RUN) 1..31' in found
    assert 'drive.pole_pairs: expected a pole pair count 1..255, got 0' in found
    assert 'drive.n_max_rpm: expected a number > 0 (rpm), got -1' in found
    assert 'drive.actual_velocity: table: expected tab_osc (0x2012) or tab_int (0x200F)' in found
    assert 'element: expected an element number 0..63, got 64' in found
    assert 'drive.position: counts_per_revolution: expected a number > 0' in found
    assert "drive.bogus: unknown OPEN drive axis setting" in found


def test_node_guarding_and_the_two_modes_are_required() -> None:
    data = example()
    del data['nodes']['opendrive']['guard_time_ms']
    del data['nodes']['opendrive']['life_time_factor']
    assert any("family 'opendrive' is supervised by node guarding" in p and 'guard_time_ms' in p
               for p in problems(data))
    data = example()
    axis_data(data)['mode'] = 'csp'
    assert any("family 'opendrive' does not accept mode csp (it takes pv, pt)" in p for p in problems(data))


def test_the_loader_refuses_objects_the_drive_cannot_map() -> None:
    data = example(rpdo={1: {'mapping': [{'index': 0x201F, 'sub_index': 0}, {'index': 0x200E, 'sub_index': 53}]}},
                   tpdo={1: {'mapping': [{'index': 0x2021, 'sub_index': 0}, {'index': 0x2001, 'sub_index': 0}]}})
    found = '\n'.join(problems(data))
    assert 'nodes.opendrive.rpdo.1.mapping[1]: object 0x200E:35' in found and 'not PDO-mappable in opendrive.eds' \
        in found
    assert 'nodes.opendrive.tpdo.1.mapping[1]: object 0x2001:00' in found


def test_family_hooks_without_a_bus() -> None:
    family = get_family('opendrive')
    assert not family.axes.has_cia402 and family.axes.max_count == 1 and not family.boot.has_heartbeat
    assert family.pdo.comm_subindices == frozenset({1, 2, 3, 5})
    assert family.modes.accepted == frozenset({3, 4})
    alarm = family.decode_emcy(NODE, 'opendrive', bytes.fromhex('00 10 03 08 00 00 00 00'), 0.0)  # §6.14
    assert (alarm.code, alarm.register, alarm.severity, alarm.is_reset) == (0x1000, 0x03, Severity.ERROR, False)
    assert alarm.text == 'alarm A3 overcurrent' and alarm.slot == 0
    several = family.decode_emcy(NODE, 'opendrive', bytes.fromhex('00 10 09 90 04 00 00 00'), 0.0)
    assert several.text == 'alarms A4 temperature, A7, A10 voltage'
    reset = family.decode_emcy(NODE, 'opendrive', bytes(8), 0.0)
    assert reset.is_reset and reset.severity is Severity.INFO and reset.text == 'alarms reset'
    partial = family.decode_emcy(NODE, 'opendrive', bytes.fromhex('00 00 01 08 00 00 00 00'), 0.0)
    assert partial.is_reset and partial.text == 'alarms reset; still active: A3 overcurrent'
    assert alarm_text(1 << 13 | 1 << 0) == 'alarms A0, A13 voltage' and alarm_text(1 << 7) == 'alarm A7'
    # the worked examples of the format words (§6.6, §6.7)
    free = Format.of((0x1131, 0, 8190, 4095))
    assert (free.access_class, free.representation, free.digits, free.decimals, free.unit) == (1, 1, 3, 1, '%')
    assert free.text(free.real(1000)) == '24.4' and free.real(8190) == pytest.approx(200.0)
    reserved = Format.of((0x2231, 5, 1000, 10))
    assert reserved.real(400) == 40.0 and reserved.real(5) == 0.5 and reserved.internal(40.0) == 400


# -- boot and supervision -------------------------------------------------------------------------
def test_boots_by_node_guarding_with_run_low_and_only_the_managed_pdo_subindices() -> None:
    data = example()
    data['nodes']['opendrive']['sdo'] = [{'index': 0x201F, 'sub_index': 0, 'value': EXTRA_BIT | RUN}]
    with bridge(data) as (master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        node = master.nodes['opendrive']
        assert node.snapshot().liveness == 'node guarding'
        assert drive.value(0x100C) == 100 and drive.value(0x100D) == 3
        writes = sdo_downloads(sniffer)
        # fieldbus RUN low and the references 0 before anything else of the configuration
        first_config = next(i for i, (index, _s, _d) in enumerate(writes) if index not in (0x201F, 0x201A, 0x201C,
                                                                                              0x201D))
        early = writes[:first_config]
        assert (0x201F, 0, bytes(4)) in early  # RUN (bit 0) cleared, no other bit was set
        assert {(0x201A, 0), (0x201C, 0), (0x201D, 0)} <= {(i, s) for i, s, d in early if d[:2] == bytes(2)}
        # RPDO communication records: sub 1 and 2 only; TPDOs: no sub 6 (the drive has none)
        rpdo_subs = {s for i, s, _d in writes if 0x1400 <= i <= 0x1403}
        tpdo_subs = {s for i, s, _d in writes if 0x1800 <= i <= 0x1803}
        assert rpdo_subs <= {1, 2} and rpdo_subs == {1, 2}
        assert tpdo_subs <= {1, 2, 3, 5} and 6 not in tpdo_subs
        # the boot SDO set RUN and another function: RUN is cleared again, the other kept
        assert drive.value(0x201F) == EXTRA_BIT
        time.sleep(0.5)
        assert all(word == EXTRA_BIT and speed == 0 and torque == 0 for word, speed, torque in rpdos(sniffer))
        assert not drive.run_input and axis.drive_state is DriveState.DISABLED
        # never declared lost while it answers
        time.sleep(1.5)
        assert node.available and not any(e.kind is EventKind.GUARDING_LOST for e in master.events)
        assert axis.snapshot().message == 'position estimated (integrated from velocity)'


def test_the_boot_fails_naming_c52_when_the_drive_ignores_can_references() -> None:
    data = with_sim(example(boot_retries=0, boot_retry_interval_ms=60000), c52=0)
    with bridge(data, wait=False) as (master, _sim, _sniffer, _axis):
        node = master.nodes['opendrive']
        eventually(lambda: 'C52' in node.boot_error, 10.0, 'a boot error naming C52')
        assert 'C52 = 0 (0x200E:35)' in node.boot_error and 'set C52 = 1' in node.boot_error
        assert not node.available


def test_the_life_time_is_clamped_to_what_the_drive_keeps() -> None:
    data = example(guard_time_ms=2000, life_time_factor=3)  # 6 s, the drive keeps 32767 / 8000 Hz = 4.096 s
    with bridge(data) as (_master, sim, _sniffer, _axis):
        assert sim.drive(NODE).value(0x100C) == 2000 and sim.drive(NODE).value(0x100D) == 2


def test_lost_while_silent_then_back_with_run_low_and_references_zero() -> None:
    data = example(guard_time_ms=50, life_time_factor=3)
    with bridge(data) as (master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        node = master.nodes['opendrive']
        enabled_at(axis, velocity=50.0)
        eventually(lambda: rpdos(sniffer) and rpdos(sniffer)[-1][:2] == (RUN, round(50.0 / SPEED_UNIT)), 2.0,
                   'RUN and the reference in the RPDO')
        drive.stop_guarding_replies(True)
        silent = time.monotonic()
        eventually(lambda: not axis.feedback()[0], 2.0, 'the joint unavailable')
        assert time.monotonic() - silent < 0.15 + BUSY_SLACK  # life time 150 ms, plus polling on a busy machine
        assert axis.drive_state is DriveState.UNAVAILABLE
        # the drive itself does nothing when the master goes (the appendix's default) and still sends
        # its TPDOs: the bridge keeps sending its stop (RUN low, references 0) until it is at rest
        eventually(lambda: not drive.running, 2.0, 'the drive stopped by the bridge')
        assert rpdos(sniffer)[-1] == (0, 0, 0)
        mark = sniffer.mark
        drive.stop_guarding_replies(False)
        eventually(lambda: node.available, 10.0, 'configured again')
        first = sniffer.wait(RPDO1, mark, timeout=2.0)[0]
        assert rpdo(first) == (0, 0, 0)  # the first frame after it came back: RUN 0, references 0
        writes = sdo_downloads(sniffer, mark)
        assert writes and writes[0] == (0x201F, 0, bytes(4))  # and before it, the boot's RUN low
        time.sleep(0.5)
        assert all(word & RUN == 0 for word, _s, _t in rpdos(sniffer, mark))
        assert not drive.run_input and axis.drive_state is not DriveState.ENABLED
        assert 'node configured again' in axis.snapshot().message


# -- intents ----------------------------------------------------------------------------------------
def test_disable_sends_reference_zero_and_run_low_in_one_rpdo_with_the_other_bits_kept() -> None:
    data = example()
    data['nodes']['opendrive']['sdo'] = [{'index': 0x201F, 'sub_index': 0, 'value': EXTRA_BIT}]
    with bridge(data) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        enabled_at(axis, velocity=20.0)
        raw = round(20.0 / SPEED_UNIT)
        eventually(lambda: drive.speed_reference_rpm > 100, 2.0, 'the speed reference applied')
        assert rpdos(sniffer)[-1] == (EXTRA_BIT | RUN, raw, 0)
        mark = sniffer.mark
        axis.disable(timeout=2.0)
        # the sniffer sees the frames on its own thread: wait for the first one that changed
        changed = eventually(lambda: next((f for f in rpdos(sniffer, mark) if f != (EXTRA_BIT | RUN, raw, 0)), None),
                             1.0, 'the disabling RPDO')
        assert changed == (EXTRA_BIT, 0, 0)  # one frame: RUN low and 0x201A = 0 together
        assert not drive.run_input and axis.drive_state is DriveState.DISABLED


def test_halt_keeps_run_and_zeroes_the_reference() -> None:
    with bridge(example()) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        enabled_at(axis, velocity=20.0)
        eventually(lambda: drive.speed_rpm > 150, 2.0, 'the motor turning')
        axis.halt(True)
        mark = sniffer.mark
        eventually(lambda: rpdos(sniffer, mark), 1.0, 'an RPDO after halt')
        assert rpdos(sniffer, mark)[-1] == (RUN, 0, 0)
        eventually(lambda: abs(drive.speed_rpm) < 5, 2.0, 'the motor stopped')
        assert drive.running and axis.drive_state is DriveState.ENABLED and axis.snapshot().halted
        with pytest.raises(JointError, match='halted'):
            axis.command(velocity=5.0)
        axis.halt(False)
        axis.command(velocity=5.0)
        eventually(lambda: rpdos(sniffer)[-1] == (RUN, round(5.0 / SPEED_UNIT), 0), 1.0, 'commands again')


def test_stopping_the_bridge_sends_run_low_and_references_zero_first() -> None:
    config = config_from(example())
    sniffer = Sniffer(config.bus.channel)  # type: ignore[arg-type]
    sim = SimulatedBus(config).start()
    master = Master(config)
    try:
        master.start()
        master.wait_until_operational(10.0)
        axis = master.axes[JOINT]
        axis.enable(timeout=3.0)
        axis.command(velocity=30.0)
        eventually(lambda: sim.drive(NODE).speed_rpm > 200, 2.0, 'the motor turning')
        master.stop()
        sent = rpdos(sniffer)
        assert sent[-1] == (0, 0, 0), sent[-5:]
        assert not sim.drive(NODE).run_input and not sim.drive(NODE).running
    finally:
        master.stop()
        sim.stop()
        sniffer.close()


def test_a_silent_velocity_stream_writes_reference_zero_and_marks_the_joint_stale() -> None:
    with bridge(example(command_timeout_ms=200)) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        enabled_at(axis)
        for _ in range(15):  # a stream: one command every 20 ms
            axis.command(velocity=10.0)
            last = time.monotonic()
            time.sleep(0.02)
        assert rpdos(sniffer)[-1] == (RUN, round(10.0 / SPEED_UNIT), 0)
        eventually(lambda: axis.snapshot().command_stale, 2.0, 'the joint stale')
        assert time.monotonic() - last > 0.18  # not before the 200 ms since the last command
        assert rpdos(sniffer)[-1] == (RUN, 0, 0)  # 0x201A = 0, RUN kept
        snapshot = axis.snapshot()
        assert 'no command for 200 ms in pv: references 0 (0x201A = 0)' in snapshot.message
        eventually(lambda: abs(drive.speed_rpm) < 5, 2.0, 'the motor stopped')
        # a set-point source (a trajectory stream) that ends is supervised the same way
        axis.set_setpoint_source(lambda now: Setpoint(velocity=-3.0))
        eventually(lambda: rpdos(sniffer)[-1] == (RUN, round(-3.0 / SPEED_UNIT), 0), 1.0, 'the stream')
        assert not axis.snapshot().command_stale
        axis.set_setpoint_source(None)
        eventually(lambda: axis.snapshot().command_stale and rpdos(sniffer)[-1] == (RUN, 0, 0), 2.0, 'stale again')


def test_velocity_reaches_the_motor_in_rpm_of_n_max() -> None:
    with bridge(example()) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        enabled_at(axis, velocity=100.0)  # rad/s -> 100 / (3000 rpm * 2pi/60) * 16384 = 5215.19 -> 5215
        eventually(lambda: rpdos(sniffer)[-1] == (RUN, 5215, 0), 1.0, '0x201A = 5215')
        # the drive takes the frame in its own thread: the sniffer may have it first on a busy machine
        eventually(lambda: drive.speed_reference_rpm == pytest.approx(5215 / 16384 * 3000), 2.0,
                   'the drive at its reference of 954.9 rpm')
        eventually(lambda: abs(drive.speed_rpm - 954.9) < 1.0, 3.0, 'the motor at 954.9 rpm')
        available, position, velocity, effort, stamp = axis.feedback()
        assert available and velocity == pytest.approx(100.0, abs=0.2)  # the motor lags its reference
        assert abs(time.time() - stamp) < 1.0
        # position integrated from the velocity TPDOs, against the motor's own angle
        start_est, start_angle = position, drive.angle_rad
        time.sleep(0.5)
        moved_est, moved_angle = axis.feedback()[1] - start_est, drive.angle_rad - start_angle
        assert moved_est == pytest.approx(moved_angle, rel=0.05)
        assert 'position estimated (integrated from velocity)' in axis.snapshot().message
        assert axis.stream_strategy() == 'cyclic-velocity' and axis.command_field() == 'velocity'


@pytest.mark.parametrize('speed_word, torque_word', [(0x0003, 0x0003), (0x00D1, 0x0002)])
def test_feedback_scaled_by_the_representation_words(speed_word: int, torque_word: int) -> None:
    """The bridge reads Tab_exp_osc 0x2004 at boot (appendix §2.6.5) and scales the velocity and
    torque elements by their words: with 0x0003 (% of 32767) or 0x00D1 (direct / 2^13) n_MAX is
    not 16384, and the joint velocity still matches the motor's."""
    data = with_sim(example(), actual_speed_representation=speed_word, actual_torque_representation=torque_word)
    with bridge(data) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        uploads = [f for f in sniffer.frames(SDO_RX) if f.data[:4] == bytes([0x40, 0x04, 0x20, 0x00])]
        assert len(uploads) == 1, 'one upload of 0x2004 at boot'
        assert axis.units.scaling.velocity_word == speed_word and axis.units.scaling.torque_word == torque_word
        enabled_at(axis, velocity=100.0)
        eventually(lambda: abs(drive.speed_rpm - 954.9) < 1.0, 3.0, 'the motor at 954.9 rpm')
        eventually(lambda: axis.feedback()[2] == pytest.approx(drive.speed_rpm * 2 * math.pi / 60, rel=0.01), 1.0,
                   'velocity feedback at the motor speed')
        assert axis.feedback()[3] == pytest.approx(drive.torque_nm, abs=0.05)


def test_a_representation_word_the_bridge_cannot_read_fails_the_boot() -> None:
    """A word outside the appendix's three forms (0x0002, 0x0003, 0x00n1) fails the boot step,
    naming the element, the table and the word."""
    family = get_family('opendrive')
    config = config_from(example()).nodes[0]
    table = struct.pack('<64H', 0x0010, 0x0002, *([0] * 62))

    class Port:
        node_id, name = config.node_id, config.name

        def __init__(self) -> None:
            self.config = config

        def sdo_read_raw(self, index: int, subindex: int = 0) -> bytes:
            assert (index, subindex) == (0x2004, 0)
            return table

    step = dict(family.node(config).boot_steps_before(Port()))['representation words 0x2003 / 0x2004']  # type: ignore[arg-type]
    with pytest.raises(Exception, match=r'actual_velocity 0x2012:01 \(tab_osc\[0\]\): representation word '
                                        r'0x0010 is not one the appendix shows'):
        step(Port())  # type: ignore[arg-type]


def test_speed_increment_reference_and_a_position_quantity() -> None:
    data = with_sim(example(), speed_reference='0x201D', position_element=2)
    axis_data(data)['drive'].update(speed_reference=0x201D,
                                    position={'table': 'tab_osc', 'element': 2, 'counts_per_revolution': 65536})
    with bridge(data) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        # 0x201D = omega * 65536 * pole pairs / (2 pi f_pwm) = 100 * 65536 * 4 / (2 pi 8000) = 521.5 -> 522
        enabled_at(axis, velocity=100.0)
        eventually(lambda: rpdos(sniffer)[-1] == (RUN, 522, 0), 1.0, '0x201D = 522')
        eventually(lambda: drive.speed_reference_rpm == pytest.approx(522 * 8000 * 60 / (65536 * 4)), 2.0,
                   'the drive at its reference of 955.8 rpm')  # its own thread may take the frame after the sniffer
        time.sleep(1.0)  # more than one revolution (16 rev/s): the INT16 position wraps, the bridge unwraps
        assert axis.feedback()[1] == pytest.approx(drive.angle_rad, abs=0.3)
        assert 'estimated' not in axis.snapshot().message


def test_effort_reaches_the_motor_in_newton_metres() -> None:
    data = with_sim(example(), control_mode='torque')
    axis_data(data)['mode'] = 'pt'
    del axis_data(data)['limits']
    with bridge(data) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        assert axis.command_field() == 'effort' and axis.stream_strategy() is None
        enabled_at(axis)
        axis.command(effort=2.5)  # N·m -> 2.5 / 10 * 4095 = 1023.75 -> 1024
        eventually(lambda: rpdos(sniffer)[-1] == (RUN, 0, 1024), 1.0, '0x201C = 1024')
        eventually(lambda: drive.torque_nm == pytest.approx(1024 / 4095 * 10.0), 2.0, 'the motor torque')
        eventually(lambda: axis.feedback()[3] == pytest.approx(2.5, abs=2 * TORQUE_UNIT), 2.0, 'effort feedback')
        with pytest.raises(JointError, match='needs pv'):
            axis.command(velocity=1.0)
        with pytest.raises(JointError, match=r"effort 90 is beyond the drive's range -80.0\d*..80.0\d* .*not wrapped"):
            axis.command(effort=90.0)  # INT16 of 4095 = T_nom: about 8 T_nom


def test_out_of_range_position_homing_and_other_modes_are_refused() -> None:
    data = example()
    del axis_data(data)['limits']  # the drive's own range, not the joint limit, refuses here
    with bridge(data) as (_master, sim, sniffer, axis):
        enabled_at(axis, velocity=10.0)
        raw = round(10.0 / SPEED_UNIT)
        # 700 rad/s is beyond 32767 units of 0x201A (2 n_MAX = 628 rad/s): refused, not wrapped
        with pytest.raises(JointError, match=r"beyond the drive's range .*refused, not wrapped"):
            axis.command(velocity=700.0)
        with pytest.raises(JointError, match="family 'opendrive' takes no position commands"):
            axis.command(position=1.0)
        with pytest.raises(JointError, match="family 'opendrive' has no homing"):
            axis.home()
        with pytest.raises(JointError, match="family 'opendrive' has no mode csp"):
            axis.set_mode('csp')
        with pytest.raises(JointError, match='has no interpolation buffer'):
            axis.push_interpolation_point(0, 1, 0)
        time.sleep(0.1)
        assert rpdos(sniffer)[-1] == (RUN, raw, 0)
        axis.set_mode('pt')
        assert axis.mode == 4
        eventually(lambda: rpdos(sniffer)[-1] == (RUN, 0, 0), 1.0, 'references 0 after the mode change')


def test_enable_fails_naming_the_terminal_when_the_drive_does_not_confirm_run() -> None:
    with bridge(example()) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        drive.set_terminal_input(0, False)  # the terminal RUN channel low
        with pytest.raises(JointError, match='terminal RUN low'):
            axis.enable(timeout=0.3)
        eventually(lambda: rpdos(sniffer)[-1][0] & RUN == 0, 1.0, 'the fieldbus RUN withdrawn')
        drive.set_terminal_input(0, True)
        time.sleep(0.3)
        assert not drive.run_input and axis.drive_state is DriveState.DISABLED


def test_fault_reset_fails_naming_the_alarm_while_its_cause_persists() -> None:
    seen = []
    with bridge(example()) as (master, sim, sniffer, axis):
        master.add_emcy_listener(seen.append)
        drive = sim.drive(NODE)
        enabled_at(axis, velocity=20.0)
        drive.inject_alarm(3, persistent=True)
        eventually(lambda: axis.drive_state is DriveState.FAULT, 2.0, 'fault')
        eventually(lambda: any(e.code == 0x1000 for e in seen), 1.0, 'the alarm EMCY')
        assert axis.last_emcy() is not None and axis.last_emcy().text == 'alarm A3 overcurrent'  # type: ignore[union-attr]
        eventually(lambda: rpdos(sniffer)[-1] == (0, 0, 0), 1.0, 'RUN dropped on the alarm')
        snapshot = axis.snapshot()
        assert snapshot.fault and snapshot.message.startswith('alarm A3 overcurrent')
        refusal = r'in fault \(last EMCY 0x1000 alarm A3 overcurrent at .*; alarm A3 overcurrent \(0x2018 = .*~/recover'
        with pytest.raises(JointError, match=refusal):
            axis.enable(timeout=0.5)
        mark = sniffer.mark
        with pytest.raises(JointError, match=r'fault reset failed: alarm A3 overcurrent still active .*cause persists'):
            axis.reset_fault(timeout=0.5)
        words = [w for w, _s, _t in rpdos(sniffer, mark)]
        assert RESET_BIT in words and words[0] & RESET_BIT == 0  # a rising edge of function 5
        eventually(lambda: rpdos(sniffer)[-1][0] & RESET_BIT == 0, 1.0, 'the reset bit low again')
        drive.clear_alarm_cause(3)
        axis.reset_fault(timeout=2.0)
        assert drive.alarms == 0 and axis.drive_state is DriveState.DISABLED
        assert any(e.is_reset for e in seen) and axis.last_emcy() is None
        time.sleep(0.2)
        assert not drive.running  # the reset does not restart the motor
        enabled_at(axis)


# -- parameters -------------------------------------------------------------------------------------
def test_parameters_with_format_words_classes_and_ranges() -> None:
    with bridge(example()) as (master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        access = master.parameter_access(NODE)
        p1 = access.read('P1')  # Free, percent of base 4095, 3.1 digits: 4095 -> 100.0 %
        assert (p1.value_text, p1.value, p1.unit, p1.minimum, p1.maximum) == ('100.0', 100.0, '%', 0.0,
                                                                              pytest.approx(200.0))
        assert p1.access == 'free (on-line)' and p1.save_needed
        c52 = access.read('c52')
        assert (c52.name, c52.value, c52.minimum, c52.maximum) == ('C52', 1.0, 0.0, 1.0)
        uploads = len([f for f in sniffer.frames(SDO_RX) if f.data[:4] == bytes([0x40, 0x01, 0x20, 0x00])])
        access.read('P2')
        assert len([f for f in sniffer.frames(SDO_RX) if f.data[:4] == bytes([0x40, 0x01, 0x20, 0x00])]) == uploads
        p2 = access.read('P2')  # Reserved, proportional, base 10: 400 -> 40.0, range 0.5 .. 100.0
        assert (p2.value, p2.minimum, p2.maximum, p2.access) == (40.0, 0.5, 100.0, 'reserved (off-line, key P60)')

        enabled_at(axis)
        mark = sniffer.mark
        with pytest.raises(ParameterError, match='P2: is a Reserved parameter: it is written only off-line, and the '
                                                 'drive is running'):
            access.write('P2', '50')
        axis.disable(timeout=2.0)
        with pytest.raises(ParameterError, match='P2: .*key P60 set, and P60 is 0'):
            access.write('P2', '50')
        with pytest.raises(ParameterError, match=r'P2: 150 is outside the range 0.5..100 \(internal 1500, allowed '
                                                 r'5..1000\); nothing was sent'):
            access.write('P2', '150')
        assert not [w for w in sdo_downloads(sniffer, mark) if w[0] == 0x200D]  # nothing sent for these
        assert access.write('P60', '1').value == 1.0  # the simulator's key
        written = access.write('P2', '55.5')
        assert written.value == 55.5 and drive.parameter(2) == 555
        assert (0x200D, 3, struct.pack('<h', 555)) in [(i, s, d[:2]) for i, s, d in sdo_downloads(sniffer, mark)]
        assert 'C63 = 1' in access.save() and drive.saved_parameter(2) == 555
        with pytest.raises(ParameterError, match='P0..P199 .* or C0..C99'):
            access.read('DRV.ACC')
        with pytest.raises(ParameterError, match='not managed'):
            access.write('P7', '1')


def test_a_position_loop_axis_takes_position_commands_through_the_speed_reference() -> None:
    data = example()
    axis_data(data)['position_loop'] = {'gain': 20.0, 'following_error': 2.0}
    axis_data(data)['limits'] = {'max_velocity': 100.0, 'max_acceleration': 2000.0}
    with bridge(data) as (_master, sim, sniffer, axis):
        drive = sim.drive(NODE)
        assert axis.stream_strategy() == 'position-loop' and axis.command_field() == 'velocity'
        enabled_at(axis)
        start = axis.feedback()[1]
        target = start + 5.0
        for _ in range(100):  # a position stream, 20 ms apart: the bridge closes the loop on 0x201A
            axis.command(position=target)
            time.sleep(0.02)
        assert axis.feedback()[1] == pytest.approx(target, abs=0.1)
        assert drive.angle_rad - start == pytest.approx(5.0, abs=0.15)  # the estimate against the motor
        assert abs(rpdos(sniffer)[-1][1]) < 200  # at rest: a small correction only
        axis.set_mode('pt')
        with pytest.raises(JointError, match='takes no position commands'):
            axis.command(position=target)


def test_an_nmt_stop_from_the_bridge_stops_the_drive_first() -> None:
    """NMT stop halts PDO traffic, and the drive would run on with its last references: the
    bridge sends RUN low and references 0 before the NMT frame."""
    with bridge(example()) as (master, sim, sniffer, axis):
        enabled_at(axis, velocity=30.0)
        eventually(lambda: sim.drive(NODE).speed_rpm > 200, 2.0, 'the motor turning')
        mark = sniffer.mark
        master.nmt(0x02, NODE)
        nmt = eventually(lambda: [f for f in sniffer.frames(0x000, mark) if bytes(f.data) == bytes([0x02, NODE])],
                         1.0, 'the NMT stop on the bus')
        before = [rpdo(f) for f in sniffer.frames(RPDO1, mark) if f.index < nmt[0].index]
        assert before and before[-1] == (0, 0, 0), before[-5:]
        eventually(lambda: sim.drive(NODE).nmt_state == 'STOPPED', 2.0, 'the drive stopped')
        assert not sim.drive(NODE).run_input
