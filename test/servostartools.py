"""A test-side master for the simulated SERVOSTAR 400/600: canopen RemoteNode SDO, raw frames and
the EMCY log on a private virtual channel (shared/drives/servostar-400-600.md)."""
from __future__ import annotations

import struct
import time
from typing import Any

import canopen
import pytest
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.resources import family_data
from drive_bridge.sim import SimServostar
from drive_bridge.sim.testing import SimBench, node_config, wait_until

EDS = family_data('servostar', 'servostar.eds')
NODE = 1
EMCY, GUARD, SDO_RX, SDO_TX = 0x80 + NODE, 0x700 + NODE, 0x600 + NODE, 0x580 + NODE
TPDO2, RPDO2 = 0x280 + NODE, 0x300 + NODE
SYNC = 0x080


def add(bench: SimBench, node_id: int = NODE, **options: Any) -> tuple[SimServostar, canopen.RemoteNode]:
    """A simulated SERVOSTAR, powered on; waits for its boot-up EMCY."""
    sim = SimServostar(node_config(node_id, eds=EDS, family='servostar'), options=options)
    sim.connect(bench.channel)
    bench.sims.append(sim)
    remote = bench.master.add_node(node_id, canopen.import_od(str(EDS), node_id))
    start = time.monotonic()
    sim.power_on()
    bench.log.wait_for(0x80 + node_id, since=start)
    return sim, remote


def write(node: canopen.RemoteNode, index: int, sub: int, fmt: str, value: Any) -> None:
    node.sdo.download(index, sub, struct.pack('<' + fmt, value))


def read(node: canopen.RemoteNode, index: int, sub: int, fmt: str) -> Any:
    return struct.unpack('<' + fmt, node.sdo.upload(index, sub))[0]


def abort_of(node: canopen.RemoteNode, index: int, sub: int, fmt: str | None = None, value: Any = 0) -> int:
    """The abort code of a write (``fmt`` given) or a read."""
    with pytest.raises(SdoAbortedError) as info:
        if fmt is None:
            node.sdo.upload(index, sub)
        else:
            write(node, index, sub, fmt, value)
    return info.value.code


def raw_sdo(bench: SimBench, request: bytes, node_id: int = NODE) -> bytes:
    """One raw SDO request frame; the response's data."""
    start = time.monotonic()
    bench.send(0x600 + node_id, request)
    return bench.log.wait_for(0x580 + node_id, since=start, timeout=1.0)[0].data


def emcys(bench: SimBench, since: float, node_id: int = NODE) -> list[bytes]:
    return [f.data for f in bench.log.frames(0x80 + node_id, since=since)]


def wait_emcy(bench: SimBench, since: float, code: int, node_id: int = NODE, timeout: float = 2.0) -> list[bytes]:
    """The EMCY frames since ``since`` once one with ``code`` and its follow-up arrived."""
    def arrived() -> bool:
        frames = emcys(bench, since, node_id)
        codes = [struct.unpack_from('<H', f)[0] for f in frames if len(f) == 8]
        return code in codes and codes.index(code) + 1 < len(codes)
    wait_until(arrived, timeout, f'EMCY 0x{code:04X} and its follow-up')
    return emcys(bench, since, node_id)


def statusword(node: canopen.RemoteNode) -> int:
    return int(read(node, 0x6041, 0, 'H'))


def enable(sim: SimServostar, node: canopen.RemoteNode) -> None:
    write(node, 0x6040, 0, 'H', 0x000F)  # directly from Switch On Disabled [4.4]
    wait_until(lambda: sim.axis_star.state.name == 'OPERATION_ENABLED', 1.0, 'Operation Enabled')


def set_mode(sim: SimServostar, node: canopen.RemoteNode, mode: int) -> None:
    write(node, 0x6060, 0, 'b', mode)
    wait_until(lambda: read(node, 0x6061, 0, 'b') == mode, 2.0, f'0x6061 = {mode}')
