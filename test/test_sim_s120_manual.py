"""The simulated SINAMICS S120 (CBC10) against its manual's procedures (Italian commissioning
manual IH2 04/2014, ``shared/drives/manuals/sinamics-s120-canopen-manual-it.txt``; section
numbers are the manual's, the facts document's in brackets), frame by frame from a raw tester:

- §4.3.1 "Procedura generale in modalità ONLINE" [2.5, 8.3]: a PDO's COB-ID invalid, its mapping
  entries written, the COB-ID valid again, with the simulator's default options;
- §4.2.4.2 "Configurazione della velocità di trasmissione e dell'indirizzo CAN" [1.3]: the node id
  from p8620 or the address switch, in effect only after POWER ON.
"""
from __future__ import annotations

import struct
import time
from collections.abc import Iterator

import pytest

from akdtools import h
from drive_bridge.sim import SimS120
from drive_bridge.sim.testing import SimBench, wait_until
from s120tools import CU, HAVE_EDS, NODE, P8630, abort_code, add, param, read, start, wait_state, write

pytestmark = pytest.mark.skipif(not HAVE_EDS, reason='no SINAMICS EDS in ../shared/realdata/eds')
SAVE = '23 10 10 01 73 61 76 65'  # 0x1010:1 = "save": every parameter of every drive object


@pytest.fixture
def bench() -> Iterator[SimBench]:
    with SimBench() as b:
        yield b


def sdo(bench: SimBench, request: str, node_id: int = NODE) -> bytes:
    """One raw SDO request (the manual's notation) to ``node_id``; the response's data."""
    since = time.monotonic()
    bench.send(0x600 + node_id, h(request))
    return bench.log.wait_for(0x580 + node_id, since=since, timeout=1.0)[0].data


def download(bench: SimBench, index: int, sub: int, value: int, node_id: int = NODE, size: int = 4) -> bytes:
    command = {1: 0x2F, 2: 0x2B, 4: 0x23}[size]
    request = struct.pack('<BHB', command, index, sub) + value.to_bytes(size, 'little').ljust(4, b'\0')
    return sdo(bench, request.hex(' '), node_id)


def confirmed(response: bytes, index: int, sub: int) -> bool:
    return response == struct.pack('<BHB4x', 0x60, index, sub)


# -- §4.3.1: online remapping -------------------------------------------------------------------------------
def test_online_remapping_as_the_manual_describes_it_with_the_default_options(bench: SimBench) -> None:
    """Axis 2's RPDO2 (0x1441 / 0x1641, Tab. 4-2): 1. COB-ID invalid, 2. p8711[0..3] = 0x68400010,
    0x68FF0020, 0, 0 (the entries; sub 0 is never written), 3. COB-ID valid. Every write is
    confirmed ``60 ..``; the PDO then carries axis 2's controlword and target velocity."""
    sim, node = add(bench)  # default options: mapping sub 0 read-write, as the real EDS
    cob = read(node, 0x1441, 1, 'I')
    assert confirmed(download(bench, 0x1441, 1, cob | 0x80000000), 0x1441, 1)  # 1. invalid (already: slot 1)
    for sub, entry in ((1, 0x68400010), (2, 0x68FF0020), (3, 0), (4, 0)):  # 2. the mapping objects
        response = download(bench, 0x1641, sub, entry)
        assert confirmed(response, 0x1641, sub), f'0x1641:{sub} = 0x{entry:08X}: {response.hex(" ")}'
    assert read(node, 0x1641, 0, 'B') == 2, 'sub 0: the number of mapped objects'
    assert confirmed(download(bench, 0x1441, 1, 0x2F0), 0x1441, 1)  # 3. valid, COB-ID 0x2F0
    start(bench, sim)
    bench.send(0x2F0, struct.pack('<Hi', 0x06, 500))
    wait_state(sim, 1, 'READY_TO_SWITCH_ON')
    assert read(node, 0x68FF, 0, 'i') == 500


def test_slot_0_rpdo_remapped_the_same_way(bench: SimBench) -> None:
    """Slot 0's RPDO1 comes valid (0x205, controlword): invalid, entries 0x60400010 + 0x60FF0020,
    valid again; an entry written while the PDO is valid is refused 0x08000022 (the state)."""
    sim, node = add(bench)
    assert abort_code(lambda: write(node, 0x1600, 1, 'I', 0x60400010)) == 0x08000022
    assert confirmed(download(bench, 0x1400, 1, 0x80000205), 0x1400, 1)
    assert confirmed(download(bench, 0x1600, 1, 0x60400010), 0x1600, 1)
    assert confirmed(download(bench, 0x1600, 2, 0x60FF0020), 0x1600, 2)
    assert confirmed(download(bench, 0x1400, 1, 0x205), 0x1400, 1)
    assert read(node, 0x1600, 0, 'B') == 2
    start(bench, sim)
    bench.send(0x205, struct.pack('<Hi', 0x06, -700))
    wait_until(lambda: read(node, 0x60FF, 0, 'i') == -700, 1.0, '0x60FF = -700')


def test_cia301_procedure_still_works_and_the_length_is_checked_when_valid(bench: SimBench) -> None:
    """A CiA 301 master's sub 0 = 0, entries, sub 0 = n (sub 0 stays 0 until n is written); a
    mapping beyond 64 bits is refused when the PDO is made valid (0x06040042)."""
    _sim, node = add(bench)
    write(node, 0x1641, 0, 'B', 0)
    write(node, 0x1641, 1, 'I', 0x68400010)
    assert read(node, 0x1641, 0, 'B') == 0
    write(node, 0x1641, 0, 'B', 1)
    assert read(node, 0x1641, 0, 'B') == 1
    for sub, entry in ((1, 0x68FF0020), (2, 0x68FF0020), (3, 0x68400010)):  # 80 bits
        write(node, 0x1641, sub, 'I', entry)
    assert read(node, 0x1641, 0, 'B') == 3
    assert abort_code(lambda: write(node, 0x1441, 1, 'I', 0x2F0)) == 0x06040042
    write(node, 0x1641, 3, 'I', 0)
    write(node, 0x1441, 1, 'I', 0x2F0)
    assert read(node, 0x1641, 0, 'B') == 2


# -- §4.2.4.2: node id by p8620 and the address switch --------------------------------------------------------
def power_cycle(bench: SimBench, sim: SimS120, node_id: int) -> list[bytes]:
    """POWER ON: off, on; the boot-up frame on 0x700 + ``node_id`` (returned: every frame on it)."""
    sim.power_off()
    since = time.monotonic()
    sim.power_on()
    return [f.data for f in bench.log.wait_for(0x700 + node_id, since=since, timeout=2.0)]


def write_p8620(bench: SimBench, value: int, node_id: int = NODE) -> None:
    """p8620 through the window on the Control Unit: p8630[0] = 1, then 0x41AC."""
    assert confirmed(download(bench, P8630, 0, CU, node_id, size=2), P8630, 0)
    assert confirmed(download(bench, 0x41AC, 0, value, node_id, size=1), 0x41AC, 0)


def test_node_id_from_p8620_takes_effect_at_power_on(bench: SimBench) -> None:
    """p8620 = 7 and saved: the drive answers on 0x605 until the POWER ON, then boots on 0x707 and
    answers on 0x607 only; p8620 reads 7 there."""
    sim, node = add(bench)
    write_p8620(bench, 7)
    assert confirmed(sdo(bench, SAVE), 0x1010, 1)
    assert sdo(bench, '40 00 10 00 00 00 00 00')[0] == 0x43, 'still node 5 before the POWER ON'
    assert sim.node_id == NODE
    assert power_cycle(bench, sim, 7) == [b'\x00']
    assert sim.node_id == 7
    since = time.monotonic()
    bench.send(0x600 + NODE, h('40 00 10 00 00 00 00 00'))
    time.sleep(0.2)
    assert not bench.log.frames(0x580 + NODE, since=since), 'node 5 is gone'
    assert confirmed(download(bench, P8630, 0, CU, 7, size=2), P8630, 0)
    assert sdo(bench, '40 AC 41 00 00 00 00 00', 7) == h('4F AC 41 00 07 00 00 00')
    emcy_cob = struct.unpack('<I', sdo(bench, '40 14 10 00 00 00 00 00', 7)[4:])[0]
    assert emcy_cob == 0x87, 'the EMCY COB-ID followed the node id'


def test_unsaved_p8620_is_lost_with_the_power(bench: SimBench) -> None:
    """A POWER ON loads the saved parameters: p8620 written but not saved leaves node id 5."""
    sim, node = add(bench)
    write_p8620(bench, 9)
    assert power_cycle(bench, sim, NODE) == [b'\x00']
    assert sim.node_id == NODE and param(node, CU, 8620, 'B') == NODE


def test_a_nonzero_address_switch_wins_and_shows_in_p8620(bench: SimBench) -> None:
    """Switch at 0x0C with p8620 = 5: node 12 after the POWER ON, p8620 reads 12; back at 0, the
    saved p8620 (5) is the node id again. Turning the switch changes nothing before POWER ON."""
    sim, _node = add(bench)
    sim.set_address_switch(12)
    assert sdo(bench, '40 00 10 00 00 00 00 00')[0] == 0x43, 'the switch is read at POWER ON only'
    assert power_cycle(bench, sim, 12) == [b'\x00']
    assert confirmed(download(bench, P8630, 0, CU, 12, size=2), P8630, 0)
    assert sdo(bench, '40 AC 41 00 00 00 00 00', 12) == h('4F AC 41 00 0C 00 00 00')
    sim.set_address_switch(0)
    power_cycle(bench, sim, NODE)
    assert sim.node_id == NODE


def test_address_switch_option_and_a_switch_beyond_127(bench: SimBench) -> None:
    """The option sets the switch at the first power-on; 0x80..0xFF is no node id: p8620 decides."""
    sim, _node = add(bench, address_switch=200)
    assert sim.node_id == NODE
    assert sdo(bench, '40 00 10 00 00 00 00 00')[0] == 0x43


def test_the_p0009_reboot_keeps_the_node_id_unless_the_option_says() -> None:
    """The reboot after p0009 = 0 is not a POWER ON: the saved p8620 waits (option
    node_id_at_reboot: the reboot reads it as well)."""
    for at_reboot, expected in ((False, NODE), (True, 7)):
        with SimBench() as b:
            sim, node = add(b, node_id_at_reboot=at_reboot)
            write_p8620(b, 7)
            assert confirmed(sdo(b, SAVE), 0x1010, 1)
            write(node, P8630, 0, 'H', CU)
            since = time.monotonic()
            write(node, 0x2009, 0, 'H', 3)  # p0009 = 3, then 0: the CU reboots
            write(node, 0x2009, 0, 'H', 0)
            b.log.wait_for(0x700 + expected, since=since, timeout=2.0)
            assert sim.node_id == expected
