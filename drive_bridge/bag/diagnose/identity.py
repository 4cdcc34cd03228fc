"""Node identity from SDO uploads (and writes) seen in the trace: device type, name,
hardware/software versions, the identity object 0x1018, and the vendor's name where known."""
from __future__ import annotations

from dataclasses import dataclass

from drive_bridge.bag.diagnose.model import Context
from drive_bridge.bag.diagnose.sdo import SdoTransaction
from drive_bridge.cia301.vendors import vendor_name

_STRINGS = {0x1008: 'device name', 0x1009: 'hardware version', 0x100A: 'software version'}
_IDENTITY = {1: 'vendor ID', 2: 'product code', 3: 'revision', 4: 'serial number'}
_PROFILES = {301: 'CiA 301 generic', 401: 'CiA 401 I/O', 402: 'CiA 402 drive', 406: 'CiA 406 encoder'}


@dataclass
class NodeIdentity:
    device_type: int | None = None
    strings: dict[str, str] | None = None
    identity: dict[str, int] | None = None
    vendor: str | None = None

    @property
    def profile(self) -> int | None:
        return self.device_type & 0xFFFF if self.device_type is not None else None

    def to_json(self) -> dict[str, object]:
        out: dict[str, object] = {}
        if self.device_type is not None:
            out['device type'] = f'0x{self.device_type:08X}'
            out['profile'] = _PROFILES.get(self.profile or 0, f'CiA {self.profile}')
        out.update(self.strings or {})
        out.update({k: f'0x{v:08X}' for k, v in (self.identity or {}).items()})
        if self.vendor:
            out['vendor'] = self.vendor
        return out


def _text(data: bytearray) -> str:
    return bytes(data).rstrip(b'\0').decode('latin-1')


class Identities:
    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.nodes: dict[int, NodeIdentity] = {}

    def sdo(self, txn: SdoTransaction) -> None:
        index = txn.index
        if index not in (0x1000, 0x1018) and index not in _STRINGS:
            return
        ident = self.nodes.setdefault(txn.node, NodeIdentity())
        if index == 0x1000 and txn.value is not None:
            ident.device_type = txn.value
        elif index in _STRINGS:
            ident.strings = {**(ident.strings or {}), _STRINGS[index]: _text(txn.data)}
        elif txn.subindex in _IDENTITY and txn.value is not None:
            ident.identity = {**(ident.identity or {}), _IDENTITY[txn.subindex]: txn.value}
            if txn.subindex == 1:
                ident.vendor = vendor_name(txn.value)

    def finish(self) -> None:
        for node, info in self.ctx.nodes.items():
            od = info.od
            if od is None or not od.device_information.vendor_name:
                continue
            ident = self.nodes.setdefault(node, NodeIdentity())
            ident.vendor = ident.vendor or f'{od.device_information.vendor_name} (from the EDS)'
