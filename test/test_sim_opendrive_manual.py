"""The simulated OPEN drive against its CAN appendix ("Allegato CAN BUS",
``shared/drives/manuals/opendrive-canbus-appendix-it.txt``; section numbers are the appendix's,
the facts document's in brackets), from a raw tester on the bus:

- §2.6.4 / §2.6.5: the representation words Tab_exp_int 0x2003 / Tab_exp_osc 0x2004 and the
  actual values they describe [3.3, 3.4];
- §2.6.8: application functions I29..I63 on a terminal input (the physical state wins) against
  the same function set by CAN, beside the standard functions' OR and RUN's AND [3.6];
- §2.4: the life guarding reaction "decided when the firmware is compiled; by default no action"
  as the simulator option ``life_guarding_reaction``, reachable from a bus configuration [2.1].
"""
from __future__ import annotations

import struct
import time
from collections.abc import Iterator
from pathlib import Path

import canopen
import pytest
import yaml

from akdtools import h
from bustools import config_from, unique_channel
from drive_bridge.families.opendrive.representation import full_scale
from drive_bridge.sim import SimOpenDrive, SimulatedBus
from drive_bridge.sim.testing import SimBench, wait_until
from opendrivetools import EMCY, HIGH, abort_code, add, read, rtr, set_param, start, write

N_MAX_RPM = 3000.0
EXAMPLE = Path(__file__).resolve().parent.parent / 'config' / 'opendrive_example.yaml'


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


# -- §2.6.4 / §2.6.5: representation words ------------------------------------------------------------------
def test_the_appendix_examples_decode_as_printed() -> None:
    """0x0002: 2040 -> 49.8 % (of 4095); 0x0041: 120 -> 7.5 (direct / 2^4); 0x0003: 5000 -> 15.2 %
    (of 32767; 15.26, the appendix truncates)."""
    assert round(2040 / full_scale(0x0002) * 100, 1) == 49.8
    assert 120 / full_scale(0x0041) == 7.5
    assert int(5000 / full_scale(0x0003) * 1000) / 10 == 15.2
    for word in (0x0000, 0x0004, 0x0102, 0x1041):
        with pytest.raises(ValueError, match=f'0x{word:04X}'):
            full_scale(word)


@pytest.mark.parametrize('word, half', [(0x00E1, 8192), (0x0003, 16384), (0x0002, 2048), (0x0041, 8)])
def test_actual_speed_follows_its_representation_word(bench: SimBench, word: int, half: int) -> None:
    """Both tables, read by segmented upload, give element 0 (the speed) the option's word and
    element 1 (the torque) 0x0002; at half n_MAX (0x201A = 8192) Tab_osc[0] and Tab_int[0] read
    half the word's 100 % figure."""
    sim, node = add(bench, actual_speed_representation=word)
    for index in (0x2003, 0x2004):
        words = struct.unpack('<64H', node.sdo.upload(index, 0))
        assert words[:3] == (word, 0x0002, 0x0000), hex(index)
    write(node, 0x201A, 0, 'h', 8192)
    wait_until(lambda: abs(sim.speed_rpm - N_MAX_RPM / 2) < 1.0, 3.0, 'half n_MAX')
    for index in (0x2012, 0x200F):
        value = read(node, index, 1, 'h')
        assert abs(value - half) <= max(1, half // 100), (hex(index), value)


def test_a_representation_word_outside_the_appendix_forms_is_refused() -> None:
    with SimBench() as bench, pytest.raises(ValueError, match="actual_torque_representation.*0x0005"):
        add(bench, actual_torque_representation=0x0005)


# -- §2.6.8: logic input functions on terminals and by CAN ------------------------------------------------------
def assign_terminal(node: canopen.RemoteNode, terminal: int, function: int) -> None:
    """Cn = function: a Reserved connection, written off-line (RUN low) with key P60."""
    write(node, 0x201F, 0, 'I', 0)  # RUN low: the drive is off-line
    set_param(node, 'P', 60, 1)  # the key (reserved_key)
    set_param(node, 'C', terminal, function)


def test_application_function_on_a_terminal_takes_the_terminal_state(bench: SimBench) -> None:
    """C3 = 30: terminal 3 controls I30 (0x2020 / 0x2022 bit 1). Terminal low and 0x2020 bit 1
    set by CAN: 0x2022 bit 1 reads 0 (the physical state imposes it); terminal high, CAN 0: 1. An
    application function no terminal controls follows CAN (I31, bit 2)."""
    sim, node = add(bench)
    assign_terminal(node, 3, 30)
    assert read(node, 0x200E, 4, 'h') == 30
    sim.set_terminal(3, False)
    write(node, 0x2020, 0, 'I', 0b110)  # I30 and I31 forced by CAN
    assert read(node, 0x2022, 0, 'I') == 0b100
    sim.set_terminal(3, True)
    write(node, 0x2020, 0, 'I', 0)
    assert read(node, 0x2022, 0, 'I') == 0b010
    write(node, 0x2020, 0, 'I', 0b100)
    assert read(node, 0x2022, 0, 'I') == 0b110 and sim.application_inputs == 0b110


def test_standard_function_on_a_terminal_is_an_or_and_run_an_and(bench: SimBench) -> None:
    """The same situation for standard functions: C3 = 1 (I01) with terminal 3 low and 0x201F bit
    1 set reads high (OR of the channels); RUN (C1 = 0) with terminal 1 low and 0x201F bit 0 set
    reads low (AND)."""
    sim, node = add(bench)
    assign_terminal(node, 3, 1)
    sim.set_terminal(3, False)
    sim.set_terminal(1, False)
    write(node, 0x201F, 0, 'I', 0b11)
    assert read(node, 0x2021, 0, 'I') & 0b11 == 0b10
    assert read(node, 0x2010, 2, 'h') == HIGH and read(node, 0x2010, 1, 'h') == 0


def test_terminal_assignment_reaches_the_application_functions_only_by_their_numbers(bench: SimBench) -> None:
    """C1..C8 take 0..63 (I00..I63); beyond, the format's maximum refuses the write."""
    _sim, node = add(bench)
    assign_terminal(node, 4, 63)
    assert read(node, 0x200E, 5, 'h') == 63
    assert abort_code(lambda: set_param(node, 'C', 4, 64)) == 0x06090031


# -- §2.4: loss of guarding, per firmware -------------------------------------------------------------------------
def guard(node: canopen.RemoteNode, bench: SimBench, guard_ms: int = 50, factor: int = 2) -> None:
    write(node, 0x100C, 0, 'H', guard_ms)
    write(node, 0x100D, 0, 'B', factor)
    rtr(bench)  # life guarding starts with the first RTR


def test_default_firmware_keeps_running_when_the_guarding_stops(bench: SimBench) -> None:
    """Life time 100 ms, RTRs stop: the drive runs on at its reference (no EMCY, RUN high)."""
    sim, node = add(bench)
    start(bench, sim)
    write(node, 0x201A, 0, 'h', 4096)  # 25 % n_MAX
    wait_until(lambda: abs(sim.speed_rpm - 750.0) < 1.0, 3.0, '750 rpm')
    since = time.monotonic()
    guard(node, bench)
    wait_until(lambda: sim.guarding_lost, 1.0, 'life guarding event')
    time.sleep(0.3)
    assert sim.running and abs(sim.speed_rpm - 750.0) < 1.0
    assert read(node, 0x2021, 0, 'I') & 1 and not [f for f in bench.log.frames(EMCY, since=since)]


def test_alarm_firmware_trips_an_alarm_reset_once_the_rtrs_are_back(bench: SimBench) -> None:
    """Option 'alarm': alarm A15 (guarding_alarm) trips, EMCY ``00 10 01 00 80 ...`` (generic
    error, register bit 0, alarm word 0x8000), the drive stops; while the RTRs stay away an alarm
    reset leaves it, once they are back the reset (rising edge of I05) clears it."""
    sim, node = add(bench, life_guarding_reaction='alarm')
    start(bench, sim)
    since = time.monotonic()
    guard(node, bench)
    frame = bench.log.wait_for(EMCY, since=since, timeout=1.5)[0].data
    assert frame == h('00 10 01 00 80 00 00 00')
    assert read(node, 0x2018, 0, 'H') == 0x8000 and not sim.running
    write(node, 0x201F, 0, 'I', 1 | 1 << 5)  # alarm reset while the cause persists
    assert read(node, 0x2018, 0, 'H') == 0x8000
    write(node, 0x201F, 0, 'I', 1)
    rtr(bench)
    wait_until(lambda: not sim.guarding_lost, 0.5, 'RTRs back')
    since = time.monotonic()
    write(node, 0x201F, 0, 'I', 1 | 1 << 5)
    assert bench.log.wait_for(EMCY, since=since)[0].data == bytes(8)
    assert read(node, 0x2018, 0, 'H') == 0 and sim.running


@pytest.mark.parametrize('reaction', ['none', 'stop', 'alarm'])
def test_the_firmware_option_is_set_from_the_bus_configuration(reaction: str) -> None:
    """``simulation.nodes.<node>.life_guarding_reaction`` reaches the simulated drive."""
    data = yaml.safe_load(EXAMPLE.read_text())
    data['bus']['channel'] = unique_channel('od-firmware')
    data['simulation'] = {'enabled': True, 'nodes': {'opendrive': {'life_guarding_reaction': reaction}}}
    drive = SimulatedBus(config_from(data)).drives[1]
    assert isinstance(drive, SimOpenDrive) and drive.options['life_guarding_reaction'] == reaction
    data['simulation']['nodes']['opendrive']['life_guarding_reaction'] = 'coast'
    with pytest.raises(ValueError, match="life_guarding_reaction.*'none', 'stop', 'alarm'"):
        SimulatedBus(config_from(data))
