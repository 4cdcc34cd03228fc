"""A test-side master for the simulated SINAMICS S120 with CBC10: the object dictionaries from
Siemens' real EDS files (../shared/realdata/eds/), canopen RemoteNode SDO and the p8630 window,
raw frames on a private virtual channel (shared/drives/sinamics-s120-cbc10.md).

The modular V4.8 file keeps its per-DO objects in CiA 306 module sections ``[MkFixed....]`` that
canopen skips: :func:`modular_od` expands them for k modules as a family would; :func:`flat_od`
copies the flat file's slot 0 to further slots at +0x40 / +0x80 / +0x800. Node 5 with two motor
drive objects, p8743 = [4, 3], unless said otherwise.
"""
from __future__ import annotations

import copy
import io
import re
import struct
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import canopen
import pytest
from canopen import ObjectDictionary
from canopen.objectdictionary import ODVariable
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.config.eds import read_object_dictionary
from drive_bridge.model import NodeConfig
from drive_bridge.sim import SimS120
from drive_bridge.sim.testing import SimBench, wait_until

EDS_DIR = Path(__file__).resolve().parents[2] / 'shared' / 'realdata' / 'eds'
MODULAR = EDS_DIR / 'SINAMICS_S120_V48__SINAMICS_S120.eds'
FLAT = EDS_DIR / 'sinamics_s120.eds'
HAVE_EDS = MODULAR.exists() and FLAT.exists()

NODE = 5
BOOT, EMCY, SDO_RX, SDO_TX = 0x700 + NODE, 0x80 + NODE, 0x600 + NODE, 0x580 + NODE
SYNC = 0x080
P8630 = 0x41B6
CU = 1
INC_PER_REV = 2048 << 11  # p0408 = 2048, p0418 = 11 (the simulator's defaults)
ENABLED = 'OPERATION_ENABLED'


# -- object dictionaries from the real EDS files ---------------------------------------------------------
def modular_od(modules: int = 2, node_id: int = NODE) -> ObjectDictionary:
    """The V4.8 modular EDS with modules 1..``modules`` as plain objects (MkFixed1440 -> 1440)."""
    lines: list[str] = []
    keep = True
    for line in MODULAR.read_bytes().decode('utf-8-sig').splitlines():
        match = re.match(r'^\[M(\d+)Fixed([0-9A-Fa-f]{4})(sub[0-9A-Fa-f]+)?\]\s*$', line)
        if match:
            keep = int(match.group(1)) <= modules
            if keep:
                lines.append(f'[{match.group(2).upper()}{match.group(3) or ""}]')
            continue
        if line.startswith('['):
            keep = True
        if keep:
            lines.append(line)
    source = io.StringIO('\n'.join(lines))
    source.name = MODULAR.name
    return canopen.import_od(source, node_id)


def _moved(index: int, slot: int) -> int | None:
    if 0x1400 <= index <= 0x1BFF and index & 0xFF < 8:
        return index + 0x40 * slot
    if 0x5800 <= index <= 0x587F:
        return index + 0x80 * slot
    if 0x6000 <= index <= 0x67FF:
        return index + 0x800 * slot
    return None


def flat_od(axes: int = 2, node_id: int = NODE) -> ObjectDictionary:
    """The flat EDS (slot 0) with slot 0's objects copied to slots 1..axes-1."""
    od, _ = read_object_dictionary(FLAT, node_id)
    for slot in range(1, axes):
        for index in [i for i in od if i < 0x6800]:
            new = _moved(index, slot)
            if new is None:
                continue
            entry = copy.deepcopy(od[index])
            entry.index, entry.name = new, f'{entry.name} (slot {slot})'
            for var in [entry] if isinstance(entry, ODVariable) else list(entry.subindices.values()):
                var.index = new
                if 0x1400 <= index <= 0x1BFF and not index & 0x200 and var.subindex == 1:
                    var.default = int(var.default or 0) | 1 << 31  # only slot 0 has predefined COB-IDs
                var.value = var.default
            od.add_object(entry)
    return od


# -- bus helpers ------------------------------------------------------------------------------------
def add(bench: SimBench, od: ObjectDictionary | None = None, **options: Any) -> tuple[SimS120, canopen.RemoteNode]:
    od = od if od is not None else modular_od()
    options = {'do_numbers': [4, 3], **options}
    sim = SimS120(NodeConfig('s120', NODE, 'sinamics_s120', od, MODULAR), options=options)
    sim.connect(bench.channel)
    bench.sims.append(sim)
    node = bench.master.add_node(NODE, od)
    start = time.monotonic()
    sim.power_on()
    bench.log.wait_for(BOOT, since=start)
    return sim, node


def write(node: canopen.RemoteNode, index: int, sub: int, fmt: str, value: Any) -> None:
    node.sdo.download(index, sub, struct.pack('<' + fmt, value))


def read(node: canopen.RemoteNode, index: int, sub: int, fmt: str) -> Any:
    return struct.unpack('<' + fmt, node.sdo.upload(index, sub))[0]


def select(node: canopen.RemoteNode, do: int) -> None:
    write(node, P8630, 0, 'H', do)


def param(node: canopen.RemoteNode, do: int, number: int, fmt: str, index: int = 0) -> Any:
    select(node, do)
    return read(node, 0x2000 + number, index, fmt)


def set_param(node: canopen.RemoteNode, do: int, number: int, fmt: str, value: Any, index: int = 0) -> None:
    select(node, do)
    write(node, 0x2000 + number, index, fmt, value)


def abort_code(call: Callable[[], Any]) -> int:
    with pytest.raises(SdoAbortedError) as info:
        call()
    return info.value.code


def emcys(bench: SimBench, since: float = 0.0) -> list[bytes]:
    return [f.data for f in bench.log.frames(EMCY, since=since)]


def emcy_frame(code: int, register: int, number: int, do: int) -> bytes:
    return struct.pack('<HBHBxx', code, register, number, do)


def state(sim: SimS120, slot: int) -> str:
    return sim.view(sim.drive_objects[slot]).state


def wait_state(sim: SimS120, slot: int, name: str, timeout: float = 2.0) -> None:
    wait_until(lambda: state(sim, slot) == name, timeout, f'slot {slot} {name} (is {state(sim, slot)})')


def enable(node: canopen.RemoteNode, sim: SimS120, slot: int) -> None:
    for cw in (0x06, 0x07, 0x0F):
        write(node, 0x6040 + 0x800 * slot, 0, 'H', cw)
    wait_state(sim, slot, ENABLED)


def start(bench: SimBench, sim: SimS120) -> None:
    bench.nmt(0x01, NODE)
    wait_until(lambda: sim.nmt_state == 'OPERATIONAL', 1.0, 'OPERATIONAL')


def rtr(bench: SimBench) -> None:
    bench.master.send_message(BOOT, b'', remote=True)


def inc_per_s(rpm: float) -> int:
    return round(rpm * INC_PER_REV / 60)
