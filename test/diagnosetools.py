"""For the diagnosis tests: a recording of the simulated bus with injected faults, and a check
that a report stands alone.

A test-side master (SimBench) drives one simulated CiA 402 drive through configuration,
enable, SYNC cycles, and five faults; a listen-only python-can bus on the same virtual channel
writes every frame (both directions) to a candump log. The wall-clock time of each fault is
returned, so a test can check the report's time of each finding.
"""
from __future__ import annotations

import struct
import threading
import time
from dataclasses import dataclass, field
from html.parser import HTMLParser
from pathlib import Path

import can
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.testing import SimBench, SyncLoop, wait_until

NODE = 5
RPDO1 = 0x200 + NODE
PERIOD = 0.01
TARGET = 12_345


@dataclass
class FaultRecording:
    path: Path
    t0: float = 0.0  # time of the first frame (the drive's power-on boot-up)
    times: dict[str, float] = field(default_factory=dict)  # fault -> wall-clock time injected
    frames: int = 0
    messages: list[can.Message] = field(default_factory=list)


def _write_pdo(remote: object, comm: int, cob: int, entries: list[int]) -> None:
    sdo = remote.sdo  # type: ignore[attr-defined]
    mapping = comm + 0x200
    sdo[comm][1].raw = 0x80000000 | cob
    sdo[mapping][0].raw = 0
    for i, entry in enumerate(entries, start=1):
        sdo[mapping][i].raw = entry
    sdo[mapping][0].raw = len(entries)
    sdo[comm][1].raw = cob


def record_faults(path: Path) -> FaultRecording:
    rec = FaultRecording(path)
    with SimBench() as bench:
        sniffer = can.Bus(interface='virtual', channel=bench.channel, receive_own_messages=False)
        writer = can.CanutilsLogWriter(str(path), channel='vcan0')
        frames: list[can.Message] = []
        notifier = can.Notifier(sniffer, [frames.append])
        try:
            sim, remote = bench.add_drive(NODE, power_on=False)
            sim.power_on()
            bench.log.wait_for(0x700 + NODE, timeout=2.0)
            bench.nmt(0x82, NODE)  # a commanded reset communication
            time.sleep(0.2)
            remote.sdo[0x1017].raw = 50
            _write_pdo(remote, 0x1800, 0x180 + NODE, [0x60410010, 0x60640020])
            _write_pdo(remote, 0x1400, RPDO1, [0x60400010, 0x607A0020])
            bench.nmt(0x01, NODE)
            controlword = [0x06]
            loop = SyncLoop(bench.master, PERIOD)
            running = threading.Event()
            running.set()

            def cycle() -> None:
                while running.is_set():
                    loop.run(5, before=lambda i: bench.send(RPDO1, struct.pack('<Hi', controlword[0], TARGET)))

            thread = threading.Thread(target=cycle, daemon=True)
            thread.start()
            time.sleep(0.2)
            controlword[0] = 0x07
            time.sleep(0.2)
            controlword[0] = 0x0F
            time.sleep(0.3)

            sim.abort_sdo_on(0x6060, 0, 0x06090030)
            rec.times['sdo-abort'] = time.time()
            try:
                remote.sdo[0x6060].raw = 8
            except SdoAbortedError:
                pass
            time.sleep(0.3)

            rec.times['emcy'] = time.time()
            sim.inject_fault(0x2310)
            time.sleep(0.3)
            controlword[0] = 0x80  # fault reset -> switch on disabled
            time.sleep(0.2)
            rec.times['skipped-step'] = time.time()
            controlword[0] = 0x0F  # enable operation straight from switch on disabled: no such transition
            time.sleep(1.3)
            controlword[0] = 0x06
            time.sleep(0.2)

            rec.times['heartbeat-loss'] = time.time()
            sim.stop_heartbeat()
            time.sleep(0.6)
            sim.start_heartbeat()
            time.sleep(0.4)

            rec.times['reboot'] = time.time()
            sim.stop_heartbeat()
            time.sleep(1.2)
            rec.times['boot-up'] = time.time()
            sim.start_heartbeat()
            sim.restart()
            bench.log.wait_for(0x700 + NODE, since=time.monotonic() - 0.05, timeout=2.0)
            time.sleep(0.1)
            remote.sdo[0x1017].raw = 50
            time.sleep(0.4)
            running.clear()
            thread.join(timeout=2.0)
            time.sleep(0.1)
        finally:
            notifier.stop()
            sniffer.shutdown()
        wait_until(lambda: bool(frames), 1.0, 'frames')
        for msg in frames:
            writer.on_message_received(msg)
        writer.stop()
        rec.t0 = frames[0].timestamp
        rec.frames = len(frames)
        rec.messages = frames
    return rec


CONFIG_YAML = """
bus: {interface: virtual, channel: diagnose_faults, bitrate: 1000000}
master: {node_id: 127, sync_period: 10000}
nodes:
  wrist_drive:
    node_id: 5
    family: generic_402
    heartbeat_producer: 50
    axes:
      - joint: wrist_joint
        scaling: {counts_per_revolution: 65536}
"""


class _Html(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: list[str] = []
        self.links: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append(tag)
        self.links += [v or '' for k, v in attrs if k in ('src', 'href', 'xlink:href')]

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def check_self_contained(html: str, plots: int = 2) -> _Html:
    """The report parses, and references nothing outside itself (no script, no URL)."""
    parser = _Html()
    parser.feed(html)
    parser.close()
    assert 'http://' not in html and 'https://' not in html
    assert 'script' not in parser.tags and 'link' not in parser.tags and 'img' not in parser.tags
    assert all(link.startswith('#') for link in parser.links), parser.links
    assert parser.tags.count('svg') >= plots  # the node timeline and the bus load at least (1 s or longer)
    return parser
