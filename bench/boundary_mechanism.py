"""How the cyclic state crosses from the bus process to the node process, measured: the
choice behind ``drive_bridge.busproc.cyclic`` (a SEQPACKET socket message per cycle).

Per cycle the bus process has one state of N joints to hand over, and the node process must
publish it at once (the /joint_states latency goal), so whatever carries it must also wake the
reader. Three candidates, each with a reader process that waits for the next state and decodes
it, at the cycle rate, in the same run:

- ``socket``: the packed state (``cyclic.pack``) as one SOCK_SEQPACKET message, sent without
  waiting (what the bridge does);
- ``shm+pipe``: the state written into shared memory under a sequence lock, plus one byte on a
  pipe to wake the reader (shared memory alone cannot wake anyone);
- ``pipe`` (the floor): one byte on a pipe, no state at all.

Printed: the sender's CPU per state (what the cycle pays) and the latency from the send to the
decoded state in the reader (p50, p99), in µs.

    .venv/bin/python -m bench boundary_mechanism [--rate 250] [--joints 4] [--seconds 5]
"""
from __future__ import annotations

import argparse
import multiprocessing
import os
import socket
import statistics
import struct
import sys
import time
from multiprocessing import shared_memory
from typing import Any

from drive_bridge.busproc import cyclic, wire

_SEQ = struct.Struct('<Q')


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float('nan')


def _reader_socket(sock: socket.socket, other: socket.socket, joints: int, out: Any) -> None:
    other.close()
    latencies = []
    lane = wire.Lane(sock)
    while True:
        data = lane.recv_bytes()
        if data is None:
            break
        state = cyclic.unpack(data, joints)
        latencies.append(time.perf_counter() - state.lag)  # lag carries the send time here
    out.send(latencies)


def _reader_shm(name: str, fd: int, other: int, joints: int, out: Any) -> None:
    os.close(other)  # the write end the fork copied: else the read never ends
    memory = shared_memory.SharedMemory(name=name)
    latencies = []
    size = cyclic.size(joints)
    while True:
        if not os.read(fd, 1):
            break
        while True:  # seqlock: an odd or changed sequence means a write in progress
            before = _SEQ.unpack_from(memory.buf, 0)[0]
            data = bytes(memory.buf[8:8 + size])
            if before % 2 == 0 and _SEQ.unpack_from(memory.buf, 0)[0] == before:
                break
        state = cyclic.unpack(data, joints)
        latencies.append(time.perf_counter() - state.lag)
    memory.close()
    out.send(latencies)


def _reader_pipe(fd: int, other: int, out: Any) -> None:
    os.close(other)
    latencies = []
    while True:
        data = os.read(fd, 8)
        if not data:
            break
        latencies.append(time.perf_counter() - struct.unpack('<d', data)[0])
    out.send(latencies)


def run(kind: str, rate: float, joints: int, seconds: float) -> tuple[float, float, float]:
    """(sender CPU per state, latency p50, p99) in seconds."""
    ctx = multiprocessing.get_context('fork')  # the readers inherit the pipes' file descriptors
    receive, send_result = ctx.Pipe(duplex=False)
    feedback = [(True, 1.0, 2.0, 3.0, time.time())] * joints
    if kind == 'socket':
        ours, theirs = wire.lane_pair()
        reader = ctx.Process(target=_reader_socket, args=(theirs, ours, joints, send_result))
        reader.start()
        theirs.close()
        lane = wire.Lane(ours)

        def send(i: int) -> None:
            lane.send_nowait(cyclic.pack(i, time.perf_counter(), 0, 0, feedback))

        def finish() -> None:
            lane.close()
    elif kind == 'shm+pipe':
        memory = shared_memory.SharedMemory(create=True, size=8 + cyclic.size(joints))
        r, w = os.pipe()
        reader = ctx.Process(target=_reader_shm, args=(memory.name, r, w, joints, send_result))
        reader.start()
        os.close(r)

        def send(i: int) -> None:
            data = cyclic.pack(i, time.perf_counter(), 0, 0, feedback)
            _SEQ.pack_into(memory.buf, 0, 2 * i + 1)
            memory.buf[8:8 + len(data)] = data
            _SEQ.pack_into(memory.buf, 0, 2 * i + 2)
            os.write(w, b'x')

        def finish() -> None:
            os.close(w)
            memory.close()
            memory.unlink()
    else:
        r, w = os.pipe()
        reader = ctx.Process(target=_reader_pipe, args=(r, w, send_result))
        reader.start()
        os.close(r)

        def send(i: int) -> None:
            os.write(w, struct.pack('<d', time.perf_counter()))

        def finish() -> None:
            os.close(w)
    time.sleep(1.0)  # the reader is up
    period = 1.0 / rate
    count = int(seconds * rate)
    cpu = 0.0
    deadline = time.perf_counter()
    for i in range(count):
        deadline += period
        delay = deadline - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        started = time.thread_time()
        send(i)
        cpu += time.thread_time() - started
    finish()
    latencies = receive.recv()
    reader.join(10)
    return cpu / count, statistics.median(latencies), _pct(latencies, 0.99)


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog='python -m bench boundary_mechanism', description=__doc__.split('\n\n')[0])
    parser.add_argument('--rate', type=float, nargs='+', default=[250.0, 1000.0], help='states per second')
    parser.add_argument('--joints', type=int, default=4)
    parser.add_argument('--seconds', type=float, default=5.0)
    args = parser.parse_args(argv)
    print(f'{args.joints} joints, {args.seconds:g} s per row; µs: sender CPU per state, send -> decoded state '
          'in the reader process (p50, p99); pipe = the floor (a wake-up alone, no state)')
    print(f'{"rate":>6} {"mechanism":10} {"send CPU":>9} {"p50":>7} {"p99":>7}')
    for rate in args.rate:
        for kind in ('socket', 'shm+pipe', 'pipe'):
            cpu, p50, p99 = run(kind, rate, args.joints, args.seconds)
            print(f'{rate:6.0f} {kind:10} {cpu * 1e6:9.1f} {p50 * 1e6:7.0f} {p99 * 1e6:7.0f}', flush=True)


if __name__ == '__main__':
    main(sys.argv[1:])
