"""Process data: the PDO payload layouts of one node, packed and unpacked on the hot path.

PDO configuration is written by canopen (``PdoMap.save``). Reception and transmission of
the cyclic data bypass canopen's PdoVariable codecs (13.5 µs per frame measured, against
1.6 µs with struct; docs/python-ecosystem.md §1.3): each PDO is compiled once into a
:class:`PdoLayout` of fields at bit offsets.
"""
from __future__ import annotations

import struct
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from canopen import ObjectDictionary
from canopen.objectdictionary import ODVariable, datatypes as dt

from drive_bridge.model import PdoConfig

ObjectKey = tuple[int, int]
# Whether an RPDO carrying an object goes out only in a cycle that wrote it (the drive
# family says: writing an interpolation point pushes it into the drive's buffer).
SentOnWrite = Callable[[int, int], bool]


def _never(_index: int, _subindex: int) -> bool:
    return False

_FLOAT = {dt.REAL32: struct.Struct('<f'), dt.REAL64: struct.Struct('<d')}


def od_variable(od: ObjectDictionary, index: int, subindex: int) -> ODVariable | None:
    """The OD entry of index:subindex, or None."""
    try:
        entry = od[index]
    except KeyError:
        return None
    if isinstance(entry, ODVariable):
        return entry if subindex == 0 else None
    try:
        return entry[subindex]
    except (KeyError, IndexError):
        return None


@dataclass(frozen=True)
class PdoField:
    """One mapped object inside a PDO payload."""

    key: ObjectKey
    offset: int  # bit offset in the payload
    bits: int
    data_type: int

    def extract(self, payload: int, raw: bytes) -> int | float:
        if self.data_type in _FLOAT and self.offset % 8 == 0:
            return float(_FLOAT[self.data_type].unpack_from(raw, self.offset // 8)[0])
        value = (payload >> self.offset) & ((1 << self.bits) - 1)
        if self.data_type in dt.SIGNED_TYPES and value >> (self.bits - 1):
            value -= 1 << self.bits
        return value

    def insert(self, payload: int, value: int | float) -> int:
        if self.data_type in _FLOAT:
            value = int.from_bytes(_FLOAT[self.data_type].pack(value), 'little')
        mask = (1 << self.bits) - 1
        return (payload & ~(mask << self.offset)) | ((int(value) & mask) << self.offset)


@dataclass(frozen=True)
class PdoLayout:
    """A compiled PDO: COB-ID, payload length and fields."""

    config: PdoConfig
    length: int  # bytes
    fields: tuple[PdoField, ...]

    @property
    def cob_id(self) -> int:
        return self.config.cob_id

    def unpack(self, data: bytes) -> Iterable[tuple[ObjectKey, int | float]]:
        payload = int.from_bytes(data, 'little')
        return ((f.key, f.extract(payload, data)) for f in self.fields)


def compile_pdo(config: PdoConfig, od: ObjectDictionary) -> PdoLayout:
    """Compile one PDO against the node's OD (data types decide signedness and floats)."""
    fields, offset = [], 0
    for entry in config.mapping:
        var = od_variable(od, entry.index, entry.subindex)
        data_type = int(var.data_type) if var is not None and var.data_type else dt.UNSIGNED32
        fields.append(PdoField((entry.index, entry.subindex), offset, entry.bits, data_type))
        offset += entry.bits
    return PdoLayout(config, (offset + 7) // 8, tuple(fields))


class ProcessImage:
    """The process data of one node: latest received values and the outputs to send.

    Inputs are written by the CAN Notifier thread (one dict assignment per object, atomic
    under the GIL) and read by anyone; outputs are set by intents and packed by the cycle.
    """

    def __init__(self, od: ObjectDictionary, rpdos: Iterable[PdoConfig], tpdos: Iterable[PdoConfig],
                 sent_on_write: SentOnWrite = _never) -> None:
        self.rx_layouts = {p.cob_id: compile_pdo(p, od) for p in tpdos if p.enabled}
        self.tx_layouts = [compile_pdo(p, od) for p in rpdos if p.enabled]
        self.inputs: dict[ObjectKey, int | float] = {}
        self.input_stamps: dict[ObjectKey, float] = {}
        self.rx_counts: dict[int, int] = {cob: 0 for cob in self.rx_layouts}
        self.rx_errors = 0
        self.last_rx_error = ''
        self._outputs: dict[int, int] = {i: 0 for i in range(len(self.tx_layouts))}
        self._on_demand = {i for i, layout in enumerate(self.tx_layouts)
                           if any(sent_on_write(*f.key) for f in layout.fields)}
        self._written: set[int] = set()
        self._output_fields: dict[ObjectKey, tuple[int, PdoField]] = {
            f.key: (i, f) for i, layout in enumerate(self.tx_layouts) for f in layout.fields}
        self._lock = threading.Lock()
        self._listeners: list[Callable[[frozenset[ObjectKey], float], None]] = []

    # inputs (TPDOs of the node) -------------------------------------------------
    def has_input(self, index: int, subindex: int = 0) -> bool:
        key = (index, subindex)
        return any(key == f.key for layout in self.rx_layouts.values() for f in layout.fields)

    def add_input_listener(self, listener: Callable[[frozenset[ObjectKey], float], None]) -> None:
        """Called (in the Notifier thread) with the keys a received TPDO updated."""
        self._listeners = [*self._listeners, listener]

    def on_tpdo(self, cob_id: int, data: bytes | bytearray, timestamp: float) -> None:
        layout = self.rx_layouts.get(cob_id)
        if layout is None:
            return
        if len(data) < layout.length:
            self.rx_errors += 1
            self.last_rx_error = (f'TPDO 0x{cob_id:03X}: {len(data)} byte(s) received, '
                                  f'mapping needs {layout.length}')
            return
        self.rx_counts[cob_id] += 1
        self.store(layout.unpack(bytes(data)), timestamp)

    def store(self, values: Iterable[tuple[ObjectKey, int | float]], timestamp: float) -> None:
        """Record received input values (from a TPDO, or polled by SDO) and tell the listeners."""
        keys = []
        for key, value in values:
            self.inputs[key] = value
            self.input_stamps[key] = timestamp
            keys.append(key)
        updated = frozenset(keys)
        for listener in self._listeners:
            listener(updated, timestamp)

    def get(self, index: int, subindex: int = 0) -> int | float | None:
        return self.inputs.get((index, subindex))

    # outputs (RPDOs to the node) ------------------------------------------------
    def has_output(self, index: int, subindex: int = 0) -> bool:
        return (index, subindex) in self._output_fields

    def set(self, index: int, subindex: int, value: int | float) -> None:
        pdo, pdo_field = self._output_fields[(index, subindex)]
        with self._lock:
            self._outputs[pdo] = pdo_field.insert(self._outputs[pdo], value)
            self._written.add(pdo)

    def output(self, index: int, subindex: int = 0) -> int | float:
        pdo, pdo_field = self._output_fields[(index, subindex)]
        payload = self._outputs[pdo]
        return pdo_field.extract(payload, payload.to_bytes(8, 'little'))

    def frames(self) -> list[tuple[int, bytes]]:
        """(COB-ID, payload) of the RPDOs to send this cycle: every enabled RPDO, except that
        one carrying interpolation data goes out only after a write (one write, one point)."""
        with self._lock:
            frames = [(layout.cob_id, self._outputs[i].to_bytes(layout.length, 'little'))
                      for i, layout in enumerate(self.tx_layouts)
                      if i not in self._on_demand or i in self._written]
            self._written.clear()
            return frames
