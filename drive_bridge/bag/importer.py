"""Importing a trace (any python-can format, IXXAT MiniMon, or another bag) into the bag layout
the bridge records: frames on ``/can/frames``, the bus config and its EDS/DCF files stored.

The frames go from the reader's plain tuples to CanFrame CDR (``FrameEncoder.pack``) and into
the MCAP writer in one loop: no message objects for candump text or bags, and the config
loader, python-can and tqdm are imported only when a config, a python-can format or the
progress bar needs them.
"""
from __future__ import annotations

import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drive_bridge.bag.candump import ERR, EXT, FD, RTR, TX
from drive_bridge.bag.errors import BagError
from drive_bridge.bag.source import Recording, open_recording
from drive_bridge.bag.writer import BagWriter, FrameEncoder

TEXT_FORMATS = ('trc', 'asc', 'candump', 'candump-screen', 'csv', 'ixxat-minimon')


@dataclass(frozen=True)
class ImportReport:
    source: Path
    format: str
    bag: Path
    frames: int
    duration: float  # s, first to last frame
    nodes: tuple[int, ...]  # node ids seen in the CANopen COB-ID ranges
    warnings: tuple[str, ...] = ()

    def summary(self) -> str:
        nodes = ', '.join(map(str, self.nodes)) or 'none'
        return (f'{self.source} ({self.format}) -> {self.bag}: {self.frames} frames, {self.duration:.1f} s, '
                f'node ids {nodes}')


def estimate_frames(recording: Recording) -> int | None:
    """Lines of a text trace (a progress bar's total; a little over the frame count)."""
    if recording.format in TEXT_FORMATS:
        with recording.path.open('rb') as stream:
            return sum(chunk.count(b'\n') for chunk in iter(lambda: stream.read(1 << 20), b''))
    return None


def node_of(cob_id: int) -> int | None:
    """The node id in a predefined-connection COB-ID (EMCY, PDOs, SDOs, NMT error control)."""
    function = cob_id & 0x780
    node = cob_id & 0x7F
    return node if node and 0x080 <= function <= 0x700 and function != 0x100 else None


def import_trace(source: Path, out: Path, config_path: Path | None = None, progress: bool = True,
                 strict: bool = True, fmt: str | None = None) -> ImportReport:
    """Write ``source`` as a bag at ``out``; nothing is left at ``out`` if the source is bad."""
    recording = open_recording(Path(source), strict, fmt)
    config_yaml, files = recording.config_yaml, dict(recording.files)
    node_ids: set[int] = set()
    if config_path is not None:
        from drive_bridge.bag.recorder import config_files
        from drive_bridge.config import load_bus_config
        config = load_bus_config(config_path)
        config_yaml, files = Path(config_path).read_text(encoding='utf-8'), config_files(config)
        node_ids = {n.node_id for n in config.nodes}
    cob_ids: set[int] = set()  # standard identifiers seen: their node ids at the end
    times: list[float] = []  # the first and the last frame's
    writer = BagWriter(Path(out), config_yaml=config_yaml, files=files)
    bar: Any = None
    try:
        if progress:
            from tqdm import tqdm  # type: ignore[import-untyped]  # no stubs installed
            bar = tqdm(total=estimate_frames(recording), unit=' frames', leave=False, desc=recording.path.name)
        writer.write_frames(_encoded(recording, cob_ids, times, bar))
        if writer.frames == 0:
            raise BagError(f'{recording.path}: the trace holds no frames')
        writer.close()
    except BaseException:
        writer.close()
        shutil.rmtree(writer.path, ignore_errors=True)
        raise
    finally:
        if bar is not None:
            bar.close()
    seen = {node for cob in cob_ids if (node := node_of(cob)) is not None}
    warnings = []
    if node_ids and not node_ids & seen:
        warnings.append(f'none of the config\'s nodes ({", ".join(map(str, sorted(node_ids)))}) appears in the '
                        f'trace (it has {", ".join(map(str, sorted(seen))) or "no node traffic"}): wrong config?')
    if recording.skipped:
        warnings.append(f'{len(recording.skipped)} unreadable line(s) skipped, the first: {recording.skipped[0]}')
    return ImportReport(recording.path, recording.format, writer.path, writer.frames,
                        (times[-1] - times[0]) if times else 0.0, tuple(sorted(seen)), tuple(warnings))


def _encoded(recording: Recording, cob_ids: set[int], times: list[float], bar: Any) -> Iterator[tuple[int, bytes]]:
    """(stamp ns, CanFrame CDR) of each frame; the standard identifiers into ``cob_ids``, the first
    and last frame's time into ``times``; BagError for a CAN FD frame (a bag holds classic frames)."""
    pack = FrameEncoder().pack
    add = cob_ids.add
    count = 0
    t = 0.0
    for count, ((t, ident, flags, data), channel, dlc) in enumerate(recording.frames_for_bag(), start=1):
        if flags & FD:  # CanFrame has no FD fields: replayed it would be a wrong classic frame
            raise BagError(f'{recording.path}: frame {count} (id 0x{ident:X} at {t:.6f}) is a CAN FD frame: '
                           'a bag holds classic CAN frames only')
        if not flags & EXT:
            add(ident)
        if count == 1:
            times.append(t)
        elif bar is not None and not count & 4095:
            bar.update(4096)
        yield pack(t, ident, bool(flags & EXT), bool(flags & RTR), bool(flags & ERR), bool(flags & TX), dlc, data,
                   channel)
    if count:
        times.append(t)
