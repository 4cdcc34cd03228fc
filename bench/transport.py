"""Transport overhead: what a bus adds between two participants, before any CANopen work.

One-way latency (frames paced at 1 kHz, the send time on CLOCK_MONOTONIC in the payload,
which every process of the machine shares) and the most frames/s one sender gets to one
receiver. ``local`` runs sender and receiver in two processes (what ``drive-bridge sim``
does); python-can's ``virtual`` has no other way than two threads of one process, which is
its best case. python-can-remote (a hub in Python over websockets) is not installed here and
so not measured.

    .venv/bin/python -m bench transport [--frames 3000]
"""
from __future__ import annotations

import argparse
import multiprocessing
import statistics
import struct
import threading
import time
import uuid
from typing import Any

import can

from drive_bridge.master.bus import open_bus

STAMP = struct.Struct('<q')
END_ID = 0x7FF


def _receive(bus: can.BusABC, frames: int, out: Any) -> None:
    delays: list[float] = []
    first = last = 0.0
    got = 0
    while got < frames:
        msg = bus.recv(5.0)
        if msg is None:
            break
        now = time.monotonic_ns()
        if got == 0:
            first = time.perf_counter()
        got += 1
        last = time.perf_counter()
        delays.append((now - STAMP.unpack_from(msg.data)[0]) / 1e9)
    out.put((got, delays, last - first))


def _receiver_process(interface: str, channel: str, frames: int, ready: Any, out: Any) -> None:
    bus = open_bus(interface, channel)
    ready.set()
    try:
        _receive(bus, frames, out)
    finally:
        bus.shutdown()


def _send(bus: can.BusABC, frames: int, pace: float) -> None:
    deadline = time.perf_counter()
    for _ in range(frames):
        if pace:
            deadline += pace
            delay = deadline - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
        bus.send(can.Message(arbitration_id=0x181, data=STAMP.pack(time.monotonic_ns()), is_extended_id=False))


def run_case(interface: str, frames: int, pace: float) -> tuple[int, list[float], float]:
    """(frames received, one-way delays in s, seconds from first to last reception)."""
    channel = f'bench-{uuid.uuid4().hex[:8]}'
    out: Any
    if interface == 'virtual':
        import queue
        out = queue.Queue()
        rx, tx = open_bus('virtual', channel), open_bus('virtual', channel)
        thread = threading.Thread(target=_receive, args=(rx, frames, out))
        thread.start()
        _send(tx, frames, pace)
        thread.join()
        rx.shutdown()
        tx.shutdown()
        result: tuple[int, list[float], float] = out.get()
        return result
    ctx = multiprocessing.get_context('spawn')
    out, ready = ctx.Queue(), ctx.Event()
    process = ctx.Process(target=_receiver_process, args=(interface, channel, frames, ready, out))
    process.start()
    ready.wait(30)
    tx = open_bus(interface, channel)
    time.sleep(0.2)
    try:
        _send(tx, frames, pace)
        result = out.get(timeout=60)
    finally:
        tx.shutdown()
        process.join(10)
    return result


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float('nan')


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog='python -m bench transport', description=__doc__.split('\n\n')[0])
    parser.add_argument('--frames', type=int, default=3000, help='frames per case (default 3000)')
    args = parser.parse_args(argv)
    print(f'{"interface":<28} {"one-way p50":>11} {"p99":>8} {"max":>8} {"frames/s":>9}')
    rows = {}
    for interface, label in (('virtual', 'virtual (threads, 1 process)'), ('local', 'local (2 processes)')):
        got, delays, _ = run_case(interface, args.frames, 0.001)
        got_blast, _, span = run_case(interface, args.frames * 3, 0.0)
        rate = (got_blast - 1) / span if span > 0 else float('nan')
        rows[interface] = (statistics.median(delays), _pct(delays, 0.99), max(delays), rate)
        p50, p99, worst, rate = rows[interface]
        print(f'{label:<28} {p50 * 1e6:9.0f}µs {p99 * 1e6:6.0f}µs {worst * 1e6:6.0f}µs {rate:9.0f}'
              + ('' if got == args.frames else f'  ({args.frames - got} lost)'))
    v, loc = rows['virtual'], rows['local']
    print(f'{"local / virtual":<28} {loc[0] / v[0]:10.2f}× {loc[1] / v[1]:7.2f}× {loc[2] / v[2]:7.2f}× '
          f'{loc[3] / v[3]:8.2f}×')
    print('python-can-remote: not installed here, not measured (its hub is Python between every pair).')
