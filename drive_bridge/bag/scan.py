"""Find the nodes on a live bus and say what they are, for a starter bus config.

One round of SDO uploads of 0x1000 (device type) goes to every node id at once and the
answers are collected within one timeout, so scanning 127 ids takes one timeout, not 127.
The nodes that answered are then asked, one SDO at a time with canopen, for 0x1008
(device name) and 0x1018 (identity), and their CiA 402 axes counted (statusword of each
slot); the drive family registry says whose drives they are.
"""
from __future__ import annotations

import struct
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import can
import canopen
from canopen.sdo.constants import EXPEDITED, REQUEST_UPLOAD, RESPONSE_ABORTED, RESPONSE_UPLOAD, SIZE_SPECIFIED
from canopen.sdo.exceptions import SdoError

from drive_bridge.bag.errors import ScanError
from drive_bridge.cia402 import objects as obj
from drive_bridge.families import IdentityMatch, families_for_identity, get_family
from drive_bridge.model import Identity

DEVICE_TYPE, DEVICE_NAME, IDENTITY = 0x1000, 0x1008, 0x1018
# CiA 301 names the SDO COB-IDs from the server's (the node's) side
SDO_SERVER_RX, SDO_SERVER_TX = 0x600, 0x580  # client -> server, server -> client
SEND_RETRIES = 5  # a full transmit queue (SocketCAN's ENOBUFS) drains in about a frame time
SEND_BACKOFF = 0.001  # s, times the attempt
_UPLOAD = struct.Struct('<BHB4s')


@dataclass(frozen=True)
class FoundNode:
    """One node that answered the scan."""

    node_id: int
    device_type: int | None  # None: the upload of 0x1000 was aborted
    device_name: str
    identity: Identity
    vendor: str  # '' when no family knows the vendor id
    family: str
    matches: tuple[tuple[IdentityMatch, str], ...]  # every family that may fit, surest first
    axes: int  # CiA 402 axes that answer (0: none or not a CiA 402 family)

    def describe(self) -> str:
        ident = self.identity
        parts = [f'node {self.node_id:3d}',
                 f'device type 0x{self.device_type:08X}' if self.device_type is not None else 'device type ?',
                 f'vendor 0x{ident.vendor_id:08X}' + (f' ({self.vendor})' if self.vendor else '')
                 if ident.vendor_id is not None else 'vendor ?',
                 f'product 0x{ident.product_code:08X}' if ident.product_code is not None else 'product ?',
                 f'rev 0x{ident.revision_number:08X}' if ident.revision_number is not None else 'rev ?',
                 f'serial {ident.serial_number}' if ident.serial_number is not None else 'serial ?']
        name = f' "{self.device_name}"' if self.device_name else ''
        fit = self.matches[0][0].name.lower().replace('_', ' ') if self.matches else 'none'
        return (', '.join(parts) + f'{name} -> family {self.family} ({fit} match'
                + (f', {self.axes} ax{"is" if self.axes == 1 else "es"}' if self.axes else '') + ')')


def parse_node_ids(text: str) -> list[int]:
    """'1-127', '2,3,10-12' -> node ids; ScanError naming the bad part."""
    ids: set[int] = set()
    for part in text.split(','):
        lo_text, _, hi_text = part.strip().partition('-')
        try:
            lo = int(lo_text, 0)
            hi = int(hi_text, 0) if hi_text else lo
        except ValueError:
            raise ScanError(f'--nodes {text!r}: {part.strip()!r} is not a node id or a range a-b') from None
        if not 1 <= lo <= hi <= 127:
            raise ScanError(f'--nodes {text!r}: {part.strip()!r} is outside the node ids 1..127')
        ids.update(range(lo, hi + 1))
    return sorted(ids)


def probe_device_types(network: canopen.Network, node_ids: Sequence[int],
                       timeout: float) -> dict[int, int | None]:
    """Node id -> device type (None: aborted) of every node answering an SDO upload of 0x1000,
    all ids asked at once."""
    answers: dict[int, int | None] = {}
    done = threading.Event()
    wanted = set(node_ids)

    def on_response(cob_id: int, data: bytearray, _timestamp: float) -> None:
        if len(data) < 8:
            return
        command, index, subindex, payload = _UPLOAD.unpack(bytes(data[:8]))
        if (index, subindex) != (DEVICE_TYPE, 0):
            return
        node_id = cob_id - SDO_SERVER_TX
        if command & 0xE0 == RESPONSE_UPLOAD and command & EXPEDITED:
            size = 4 - ((command >> 2) & 0x3) if command & SIZE_SPECIFIED else 4
            answers[node_id] = int.from_bytes(payload[:size], 'little')
        elif command == RESPONSE_ABORTED:
            answers[node_id] = None
        if wanted <= answers.keys():
            done.set()

    for node_id in node_ids:
        network.subscribe(SDO_SERVER_TX + node_id, on_response)
    try:
        for node_id in node_ids:
            _send(network, SDO_SERVER_RX + node_id, _UPLOAD.pack(REQUEST_UPLOAD, DEVICE_TYPE, 0, bytes(4)))
        done.wait(timeout)
    finally:
        for node_id in node_ids:
            network.unsubscribe(SDO_SERVER_TX + node_id, on_response)
    return dict(sorted(answers.items()))


def _send(network: canopen.Network, cob_id: int, data: bytes) -> None:
    """One request; a full transmit queue is waited out a few times, then a ScanError."""
    for attempt in range(1, SEND_RETRIES + 1):
        try:
            network.send_message(cob_id, data)
            return
        except can.CanError as exc:
            if attempt == SEND_RETRIES:
                raise ScanError(f'sending the SDO request 0x{cob_id:03X} failed {SEND_RETRIES} times: {exc} '
                                '(the interface\'s transmit queue stays full, or the bus is off)') from exc
            time.sleep(SEND_BACKOFF * attempt)


def _upload(node: canopen.RemoteNode, index: int, subindex: int = 0) -> bytes | None:
    try:
        return node.sdo.upload(index, subindex)
    except SdoError:
        return None


def _u32(raw: bytes | None) -> int | None:
    return int.from_bytes(raw[:4].ljust(4, b'\0'), 'little') if raw else None


def identify(network: canopen.Network, node_id: int, device_type: int | None, timeout: float) -> FoundNode:
    """Device name, identity, family and axis count of a node that answered."""
    node = canopen.RemoteNode(node_id, canopen.ObjectDictionary())
    node.sdo.RESPONSE_TIMEOUT = timeout
    network.add_node(node)
    try:
        name_raw = _upload(node, DEVICE_NAME)
        device_name = name_raw.decode('latin-1').rstrip('\0 ') if name_raw else ''
        count = _u32(_upload(node, IDENTITY, 0)) or 0
        values = [_u32(_upload(node, IDENTITY, sub)) if sub <= count else None for sub in range(1, 5)]
        identity = Identity(device_type, *values)
        matches = tuple(families_for_identity(identity, device_name))
        family = matches[0][1] if matches else 'generic_301'
        axes = count_axes(node, family)
    finally:
        del network[node_id]  # leaves the node's SDO subscription
    vendor = next((v for _, f in matches if (v := get_family(f).vendor_name(identity.vendor_id or 0))), '')
    return FoundNode(node_id, device_type, device_name, identity, vendor, family, matches, axes)


def count_axes(node: canopen.RemoteNode, family: str) -> int:
    """CiA 402 axes whose statusword (0x6041 + 0x800 per slot) answers, up to the family's maximum."""
    drive = get_family(family)
    if not drive.axes.has_cia402:
        return min(drive.axes.max_count, 1)
    axes = 0
    for slot in range(max(drive.axes.max_count, 1)):
        if _upload(node, obj.for_axis(obj.STATUSWORD, slot)) is None:
            break
        axes += 1
    return axes


def scan(network: canopen.Network, node_ids: Iterable[int], timeout: float = 0.2,
         on_node: Callable[[FoundNode], None] | None = None) -> list[FoundNode]:
    """Every node among ``node_ids`` that answers, identified."""
    ids = list(node_ids)
    device_types = probe_device_types(network, ids, timeout)
    found = []
    for node_id, device_type in device_types.items():
        node = identify(network, node_id, device_type, timeout)
        found.append(node)
        if on_node is not None:
            on_node(node)
    return found
