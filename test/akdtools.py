"""A raw test-side CANopen master for the AKD worked examples: frames in, frames out.

``Sniffer`` records every frame on the virtual channel (the master's own included) with the
timestamp the virtual bus gave it when it was sent: the same stamp the simulated drives
see, so a test knows the drives' SYNC clock exactly. ``RawMaster`` sends the manual's frames
as printed (hex) and checks the drive's answers byte for byte.
"""
from __future__ import annotations

import struct
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import can

from drive_bridge.sim import SimAkd
from drive_bridge.sim.testing import AKD_EDS, SimBench, unique_channel

SYNC = 0x080


def h(text: str) -> bytes:
    """Bytes from the manual's notation: '23 01 14 01 01 03 00 80'."""
    return bytes.fromhex(text)


@dataclass(frozen=True)
class BusFrame:
    index: int  # position in the recording
    stamp: float  # time.time() when the frame was sent (virtual bus)
    cob_id: int
    data: bytes
    remote: bool


class Sniffer:
    """Every frame on a channel (``virtual`` by default; ``local`` for a bus process's bus), in
    bus order. It also sends (:meth:`send`): a test injects frames through the bus it listens on."""

    def __init__(self, channel: str, interface: str = 'virtual') -> None:
        self._bus = can.Bus(interface=interface, channel=channel, receive_own_messages=False)
        self._frames: list[BusFrame] = []
        self._cond = threading.Condition()
        self._notifier = can.Notifier(self._bus, [self._on_message], timeout=0.05)

    def _on_message(self, msg: can.Message) -> None:
        with self._cond:
            self._frames.append(BusFrame(len(self._frames), msg.timestamp, msg.arbitration_id, bytes(msg.data),
                                         msg.is_remote_frame))
            self._cond.notify_all()

    @property
    def mark(self) -> int:
        """Index of the next frame to come (use as ``after`` for what follows)."""
        with self._cond:
            return len(self._frames)

    def frames(self, cob_id: int | None = None, after: int = 0) -> list[BusFrame]:
        with self._cond:
            return [f for f in self._frames[after:] if cob_id is None or f.cob_id == cob_id]

    def wait(self, cob_id: int, after: int, count: int = 1, timeout: float = 1.0,
             data: bytes | None = None) -> list[BusFrame]:
        """The first ``count`` frames on ``cob_id`` (carrying ``data``, if given) recorded at or
        after ``after``."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                found = [f for f in self._frames[after:] if f.cob_id == cob_id and (data is None or f.data == data)]
                if len(found) >= count:
                    return found[:count]
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(f'timed out waiting for {count} frame(s) on 0x{cob_id:03X} '
                                         f'(got {[f.data.hex(" ") for f in found]})')
                self._cond.wait(left)

    def send(self, msg: can.Message) -> None:
        self._bus.send(msg)

    def close(self) -> None:
        self._notifier.stop()
        self._bus.shutdown()


class RawMaster:
    """The manual's master: raw frames, one SDO request outstanding at a time."""

    def __init__(self, bench: SimBench, sniffer: Sniffer) -> None:
        self.bench = bench
        self.sniffer = sniffer

    def send(self, cob_id: int, data: bytes) -> int:
        """Send a frame; returns its index in the recording. (Found by content: frames that
        others sent just before may not be recorded yet when the mark is taken.)"""
        mark = self.sniffer.mark
        self.bench.send(cob_id, data)
        return self.sniffer.wait(cob_id, mark, data=bytes(data))[0].index

    def sync(self) -> BusFrame:
        mark = self.sniffer.mark
        self.bench.send(SYNC, b'')
        return self.sniffer.wait(SYNC, mark, data=b'')[0]

    def sdo(self, node_id: int, request: bytes, timeout: float = 1.0) -> bytes:
        """One SDO request and the drive's response frame (8 bytes)."""
        sent = self.send(0x600 + node_id, request)
        return self.sniffer.wait(0x580 + node_id, sent + 1, timeout=timeout)[0].data

    def download(self, node_id: int, request: str | bytes) -> None:
        """An expedited download as printed in the manual; the drive must answer 60 idx sub 00.."""
        frame = h(request) if isinstance(request, str) else request
        response = self.sdo(node_id, frame)
        expected = bytes([0x60]) + frame[1:4] + bytes(4)
        assert response == expected, (f'0x{0x600 + node_id:03X}: {frame.hex(" ")} answered {response.hex(" ")}, '
                                      f'expected {expected.hex(" ")}')

    def upload(self, node_id: int, index: int, subindex: int = 0) -> bytes:
        """An SDO upload: the whole response frame (checked to be an expedited upload)."""
        response = self.sdo(node_id, struct.pack('<BHB4x', 0x40, index, subindex))
        assert response[0] & 0xF3 == 0x43 and response[1:4] == struct.pack('<HB', index, subindex), \
            f'upload 0x{index:04X}:{subindex:02X} answered {response.hex(" ")}'
        return response

    def read_u32(self, node_id: int, index: int, subindex: int = 0, signed: bool = False) -> int:
        return int.from_bytes(self.upload(node_id, index, subindex)[4:8], 'little', signed=signed)

    def read_i32(self, node_id: int, index: int, subindex: int = 0) -> int:
        return self.read_u32(node_id, index, subindex, signed=True)

    def expect(self, cob_id: int, data: str | bytes, after: int, timeout: float = 1.0) -> BusFrame:
        """The next frame on ``cob_id`` after ``after`` carries exactly ``data``."""
        frame = self.sniffer.wait(cob_id, after, timeout=timeout)[0]
        wanted = h(data) if isinstance(data, str) else data
        assert frame.data == wanted, f'0x{cob_id:03X}: got {frame.data.hex(" ")}, expected {wanted.hex(" ")}'
        return frame

    def expect_later(self, cob_id: int, data: str | bytes, after: int, timeout: float = 1.0) -> BusFrame:
        """Some frame on ``cob_id`` after ``after`` carries exactly ``data``."""
        wanted = h(data) if isinstance(data, str) else data
        deadline = time.monotonic() + timeout
        while True:
            for frame in self.sniffer.frames(cob_id, after):
                if frame.data == wanted:
                    return frame
            seen = [f.data.hex(' ') for f in self.sniffer.frames(cob_id, after)]
            assert time.monotonic() < deadline, f'0x{cob_id:03X}: no {wanted.hex(" ")} among {seen}'
            time.sleep(0.005)


@contextmanager
def akd_bus(*node_ids: int, options: dict | None = None) -> Iterator[tuple[SimBench, Sniffer, RawMaster, list[SimAkd]]]:
    """Simulated AKDs on a fresh virtual channel, a sniffer and a raw master; all stopped after."""
    channel = unique_channel('akd')
    sniffer = Sniffer(channel)
    bench = SimBench(channel)
    try:
        sims = [bench.add_drive(node_id, eds=AKD_EDS, family='akd', options=options)[0] for node_id in node_ids]
        yield bench, sniffer, RawMaster(bench, sniffer), sims  # type: ignore[misc]
    finally:
        bench.close()
        sniffer.close()
