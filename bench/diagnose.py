"""Diagnosis benchmark: frames/s of import + diagnose (``open_recording`` + ``diagnose``,
the work ``drive-bridge diagnose`` does before it writes the report), on the real traces of
../shared/realdata and on a large synthetic trace of a 4-drive bus (1 kHz SYNC, RPDO and TPDO
per drive and cycle, heartbeats, the PDO mapping configured by SDO at the start), against a
naive baseline in the same run: the straightforward design, where every frame becomes an event
record (function code, node, payload, and for SDO the object's canopen OD entry) handed to
every analyser, each filtering for what it wants, and PDOs decoded through canopen's
object-dictionary variables (given the synthetic trace's mapping, which it does not learn).

    .venv/bin/python -m bench diagnose [--frames 300000] [--repeat 3]
"""
from __future__ import annotations

import argparse
import statistics
import struct
import tempfile
import time
from collections.abc import Callable, Iterable
from functools import lru_cache
from pathlib import Path
from typing import Any

import can
import canopen

from drive_bridge.bag.diagnose import diagnose
from drive_bridge.bag.source import open_recording
from drive_bridge.bag.writer import BagWriter
from drive_bridge.cia402.statemachine import State, state_from_statusword
from drive_bridge.resources import family_data

TRACES = Path(__file__).resolve().parents[2] / 'shared' / 'realdata' / 'traces'
NODES = (2, 3, 4, 5)
CONFIG = 'master: {sync_period: 1000}\nnodes:\n' + ''.join(
    f'  drive{n}: {{node_id: {n}, family: generic_402, axes: [{{joint: joint{n}}}]}}\n' for n in NODES)


def synthetic(frames: int) -> list[can.Message]:
    """A CiA 402 bus: mapping by SDO, NMT start, then SYNC + RPDO1 + TPDO1 per drive at 1 kHz."""
    out: list[can.Message] = []
    t = 1_700_000_000.0

    def add(cob: int, data: bytes, dt: float = 0.00002) -> None:
        nonlocal t
        t += dt
        out.append(can.Message(timestamp=t, arbitration_id=cob, data=data, is_extended_id=False))

    for node in NODES:
        add(0x700 + node, b'\0')
        for index, entries in ((0x1A00, (0x60410010, 0x60640020)), (0x1600, (0x60400010, 0x607A0020))):
            writes = [(0, 0)] + [(i, e) for i, e in enumerate(entries, 1)] + [(0, len(entries))]
            for sub, value in writes:
                add(0x600 + node, struct.pack('<BHBI', 0x23, index, sub, value))
                add(0x580 + node, struct.pack('<BHBI', 0x60, index, sub, 0))
    add(0x000, b'\x01\x00')
    cycle = 0
    while len(out) < frames:
        cycle += 1
        t = 1_700_000_001.0 + cycle * 0.001
        add(0x080, b'', 0)
        for node in NODES:
            add(0x200 + node, struct.pack('<Hi', 0x0F, cycle * 10))
            add(0x180 + node, struct.pack('<Hi', 0x1237, cycle * 10 - 3))
            if cycle % 100 == node:
                add(0x700 + node, b'\x05')
    return out[:frames]


@lru_cache(maxsize=1)
def standard_od() -> canopen.ObjectDictionary:
    return canopen.import_od(str(family_data('generic402', 'generic402.eds')), 1)


class NaiveDiagnosis:
    """The baseline: one event dict per frame, every analyser sees every event."""

    def __init__(self) -> None:
        self.od = standard_od()  # read once, as the diagnosis's own (not timed)
        self.analysers: list[Callable[[dict[str, Any]], None]] = [
            self._nmt, self._heartbeat, self._sdo, self._emcy, self._pdo, self._sync]
        self.counts: dict[str, int] = {}
        self.pdo_last: dict[int, float] = {}
        self.sync_times: list[float] = []
        self.sdo_open: dict[int, dict[str, Any]] = {}
        self.sdo_log: list[tuple[float, float, Any]] = []
        self.heartbeats: dict[int, list[float]] = {}
        self.states: dict[int, State] = {}
        self.demand: dict[int, int] = {}
        self.errors: list[int] = []
        # the synthetic trace's mapping (this baseline is not asked to learn it)
        self.mapping = {0x180 + n: (self.od[0x6041], self.od[0x6064]) for n in NODES}
        self.mapping.update({0x200 + n: (self.od[0x6040], self.od[0x607A]) for n in NODES})

    def run(self, frames: Iterable[can.Message]) -> int:
        n = 0
        for msg in frames:
            n += 1
            cob = msg.arbitration_id
            event: dict[str, Any] = {'t': msg.timestamp, 'cob': cob, 'fc': cob >> 7, 'node': cob & 0x7F,
                                     'data': bytes(msg.data), 'rtr': msg.is_remote_frame, 'object': None}
            if 0x580 < cob < 0x680 and len(msg.data) >= 4:
                index, sub = struct.unpack_from('<HB', msg.data, 1)
                try:
                    event['object'] = self.od.get_variable(index, sub)
                except KeyError:
                    pass
            for analyse in self.analysers:
                analyse(event)
        return n

    def _count(self, key: str) -> None:
        self.counts[key] = self.counts.get(key, 0) + 1

    def _nmt(self, e: dict[str, Any]) -> None:
        if e['cob'] == 0:
            self._count('nmt')

    def _heartbeat(self, e: dict[str, Any]) -> None:
        if e['fc'] == 14 and not e['rtr']:
            self.heartbeats.setdefault(e['node'], []).append(e['t'])

    def _sdo(self, e: dict[str, Any]) -> None:
        """Pair requests and responses per node; decode expedited values with the OD variable."""
        if e['fc'] == 12:
            self.sdo_open[e['node']] = e
        elif e['fc'] == 11 and e['node'] in self.sdo_open:
            request = self.sdo_open.pop(e['node'])
            data = e['data']
            self.sdo_log.append((request['t'], e['t'] - request['t'], request['object']))
            variable = e['object']
            if variable is not None and data and data[0] & 0xE3 == 0x43 and len(data) == 8:
                try:
                    variable.decode_raw(data[4:4 + len(variable) // 8])
                except Exception:  # noqa: BLE001  (a baseline: a bad frame is skipped)
                    pass

    def _emcy(self, e: dict[str, Any]) -> None:
        if e['fc'] == 1 and e['node']:
            self._count('emcy')

    def _pdo(self, e: dict[str, Any]) -> None:
        """Decode every PDO through canopen's OD variables (mapping as the trace configured it)."""
        if not 3 <= e['fc'] <= 10:
            return
        self.pdo_last[e['cob']] = e['t']
        data, offset = e['data'], 0
        for variable in self.mapping.get(e['cob'], ()):
            size = len(variable) // 8
            if offset + size > len(data):
                break
            value = variable.decode_raw(data[offset:offset + size])
            offset += size
            if variable.index == 0x6041:
                self.states[e['node']] = state_from_statusword(value)
            elif variable.index == 0x607A:
                self.demand[e['node']] = value
            elif variable.index == 0x6064 and e['node'] in self.demand:
                self.errors.append(self.demand[e['node']] - value)

    def _sync(self, e: dict[str, Any]) -> None:
        if e['cob'] == 0x80:
            self.sync_times.append(e['t'])


def best_rate(work: Callable[[], int], repeat: int) -> float:
    rates = []
    for _ in range(repeat):
        start = time.perf_counter()
        n = work()
        rates.append(n / (time.perf_counter() - start))
    return max(rates)


def measure(path: Path, repeat: int) -> tuple[int, float, float, float, float, float]:
    """frames, and frames/s of: import only, diagnose only, naive only, import + diagnose,
    import + naive (the "only" runs on frames read into memory before)."""
    recording = open_recording(path)
    frames = list(recording.frames())
    raw = list(recording.raw_frames())
    diagnose(recording)  # warm the caches (the standard object dictionary) once
    NaiveDiagnosis().run(frames)
    alone = best_rate(lambda: diagnose(recording, frames=raw).frames, repeat)
    naive_alone = best_rate(lambda: NaiveDiagnosis().run(frames), repeat)
    read = best_rate(lambda: sum(1 for _ in open_recording(path).raw_frames()), repeat)
    ours = best_rate(lambda: diagnose(open_recording(path)).frames, repeat)
    naive = best_rate(lambda: NaiveDiagnosis().run(open_recording(path).frames()), repeat)
    return len(frames), read, alone, naive_alone, ours, naive


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog='python -m bench diagnose', description=__doc__.split('\n\n')[0])
    parser.add_argument('--frames', type=int, default=300_000, help='frames of the synthetic trace')
    parser.add_argument('--repeat', type=int, default=3, help='runs per row (the best is shown)')
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp) / 'synthetic.log'
        writer = can.CanutilsLogWriter(str(big), channel='can0')
        for msg in synthetic(args.frames):
            writer.on_message_received(msg)
        writer.stop()
        bag = Path(tmp) / 'synthetic_bag'
        with BagWriter(bag, config_yaml=CONFIG) as bag_writer:
            for msg in synthetic(min(args.frames, 100_000)):
                bag_writer.write_frame(msg, 'can0')
        paths = sorted(p for p in TRACES.iterdir() if p.is_file()) if TRACES.is_dir() else []
        for path in [*paths, big, bag]:
            rows.append((path.name, *measure(path, args.repeat)))
    print('frames/s (best of --repeat runs); "alone": on frames already in memory')
    print(f'{"trace":58} {"frames":>8} {"import":>9} {"diagnose":>9} {"naive":>9} {"ratio":>6} '
          f'{"import+diagnose":>16} {"import+naive":>13} {"ratio":>6}')
    print(f'{"":58} {"":8} {"":9} {"alone":>9} {"alone":>9}')
    for name, frames, read, alone, naive_alone, ours, naive in rows:
        print(f'{name:58} {frames:8d} {read:9,.0f} {alone:9,.0f} {naive_alone:9,.0f} {alone / naive_alone:6.2f} '
              f'{ours:16,.0f} {naive:13,.0f} {ours / naive:6.2f}')
    big = [r for r in rows if r[1] >= 10_000]
    print(f'median import+diagnose over inputs >= 10k frames: {statistics.median(r[5] for r in big):,.0f} frames/s '
          f'(target >= 100,000); naive: {statistics.median(r[6] for r in big):,.0f} frames/s')

if __name__ == '__main__':
    main()
