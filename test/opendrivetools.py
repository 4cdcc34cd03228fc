"""A test-side master for the simulated OPEN drive: canopen RemoteNode with the shipped EDS, raw
frames on a private virtual channel (shared/drives/opendrive.md). Node 5; the simulator's
defaults: n_MAX = 3000 rpm, T_nom = 10 N m, 4 pole pairs, f_pwm = 8 kHz, array element k at
sub-index k + 1."""
from __future__ import annotations

import struct
import time
from typing import Any

import canopen
import pytest
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.resources import family_data
from drive_bridge.sim import SimOpenDrive
from drive_bridge.sim.testing import SimBench, wait_until

EDS = family_data('opendrive', 'opendrive.eds')
NODE = 5
GUARD, EMCY, SDO_RX, SDO_TX = 0x700 + NODE, 0x80 + NODE, 0x600 + NODE, 0x580 + NODE
TPDO1, RPDO1 = 0x180 + NODE, 0x200 + NODE
PRE_OPERATIONAL, OPERATIONAL = 0x7F, 0x05
HIGH = 32767


def add(bench: SimBench, **options: Any) -> tuple[SimOpenDrive, canopen.RemoteNode]:
    sim, node = bench.add_drive(NODE, eds=EDS, family='opendrive', options=options)
    assert isinstance(sim, SimOpenDrive)
    return sim, node


def write(node: canopen.RemoteNode, index: int, sub: int, fmt: str, value: int) -> None:
    node.sdo.download(index, sub, struct.pack('<' + fmt, value))


def read(node: canopen.RemoteNode, index: int, sub: int, fmt: str) -> int:
    return struct.unpack('<' + fmt, node.sdo.upload(index, sub))[0]


def abort_code(call: Any) -> int:
    with pytest.raises(SdoAbortedError) as info:
        call()
    return info.value.code


def start(bench: SimBench, sim: SimOpenDrive) -> None:
    bench.nmt(0x01, NODE)
    wait_until(lambda: sim.nmt_state == 'OPERATIONAL', 0.5, 'OPERATIONAL')


def rtr(bench: SimBench, cob: int = GUARD) -> bytes:
    t = time.monotonic()
    bench.master.send_message(cob, b'', remote=True)
    return bench.log.wait_for(cob, since=t, timeout=0.5)[0].data


def emcy_frames(bench: SimBench, since: float = 0.0) -> list[bytes]:
    return [f.data for f in bench.log.frames(EMCY, since=since)]


def set_param(node: canopen.RemoteNode, letter: str, number: int, value: int) -> None:
    write(node, 0x200D if letter == 'P' else 0x200E, number + 1, 'h', value if value < 0x8000 else value - 0x10000)


def power_cycle(bench: SimBench, sim: SimOpenDrive) -> None:
    sim.power_off()
    t = time.monotonic()
    sim.power_on()
    bench.log.wait_for(GUARD, since=t)
    wait_until(lambda: sim.nmt_state == 'PRE-OPERATIONAL', 0.5)
