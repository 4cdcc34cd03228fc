"""Typed, serialized SDO access to one node.

canopen's SdoClient is not thread-safe (one response queue per client, no lock), so
every SDO of a node goes through one :class:`SdoChannel` holding a lock. Values are
encoded and decoded by canopen's own ODVariable codecs for the CiA 301 basic types;
a failure becomes an :class:`SdoError` naming node, object, abort code and reason.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TypeVar

import can
import canopen
from canopen.objectdictionary import ODVariable, datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from drive_bridge.master.errors import ObjectAddress, SdoError

SdoPlain = bool | int | float | str | bytes
_T = TypeVar('_T')

# CiA 301 basic data types the bridge reads and writes (codes as in SdoValue.msg)
TYPE_NAMES: dict[int, str] = {
    dt.BOOLEAN: 'BOOLEAN', dt.INTEGER8: 'INTEGER8', dt.INTEGER16: 'INTEGER16',
    dt.INTEGER32: 'INTEGER32', dt.UNSIGNED8: 'UNSIGNED8', dt.UNSIGNED16: 'UNSIGNED16',
    dt.UNSIGNED32: 'UNSIGNED32', dt.REAL32: 'REAL32', dt.VISIBLE_STRING: 'VISIBLE_STRING',
    dt.OCTET_STRING: 'OCTET_STRING', dt.UNICODE_STRING: 'UNICODE_STRING', dt.DOMAIN: 'DOMAIN',
    dt.REAL64: 'REAL64', dt.INTEGER64: 'INTEGER64', dt.UNSIGNED64: 'UNSIGNED64',
    dt.INTEGER24: 'INTEGER24', dt.UNSIGNED24: 'UNSIGNED24',
    dt.INTEGER40: 'INTEGER40', dt.UNSIGNED40: 'UNSIGNED40', dt.INTEGER48: 'INTEGER48',
    dt.UNSIGNED48: 'UNSIGNED48', dt.INTEGER56: 'INTEGER56', dt.UNSIGNED56: 'UNSIGNED56',
}
AUTO = 0

# abort codes canopen does not name (CiA 301 table 22)
EXTRA_ABORT_TEXTS = {
    0x05040001: 'client/server command specifier not valid or unknown',
    0x060A0023: 'resource not available: SDO connection',
}


def abort_text(code: int) -> str:
    """Human text of an SDO abort code (CiA 301)."""
    text = SdoAbortedError.CODES.get(code) or EXTRA_ABORT_TEXTS.get(code)
    return text[0].lower() + text[1:] if text else 'unknown abort code'


def type_name(data_type: int) -> str:
    return TYPE_NAMES.get(data_type, f'type 0x{data_type:02X}')


def od_data_type(od: canopen.ObjectDictionary, node_id: int, index: int, subindex: int) -> int:
    """Data type of an object in a node's EDS; SdoError when it is not there."""
    where = ObjectAddress(node_id, index, subindex)
    try:
        entry = od[index]
    except KeyError:
        raise SdoError(where, 'object is not in the node\'s EDS; give its data type explicitly') from None
    if not isinstance(entry, ODVariable):
        try:
            entry = entry[subindex]
        except (KeyError, IndexError):
            raise SdoError(where, 'sub-index is not in the node\'s EDS; give the data type explicitly') from None
    elif subindex != 0:
        raise SdoError(where, 'object is a plain variable: its only sub-index is 0')
    return int(entry.data_type or 0)


def _codec(index: int, subindex: int, data_type: int) -> ODVariable:
    var = ODVariable('value', index, subindex)
    var.data_type = data_type
    return var


def encode(data_type: int, value: SdoPlain, where: ObjectAddress) -> bytes:
    """Bytes of ``value`` as ``data_type``; SdoError when it does not fit."""
    if data_type not in TYPE_NAMES:
        raise SdoError(where, f'unsupported data type code 0x{data_type:02X}')
    name = type_name(data_type)
    try:
        if data_type in (dt.OCTET_STRING, dt.DOMAIN):
            return bytes(value)  # type: ignore[arg-type]
        if data_type == dt.BOOLEAN:
            if not isinstance(value, (bool, int)) or int(value) not in (0, 1):
                raise ValueError(f'{value!r} is not a boolean')
            return b'\x01' if value else b'\x00'
        if data_type in dt.INTEGER_TYPES:
            if isinstance(value, bool) or not isinstance(value, int):
                raise ValueError(f'{value!r} is not an integer')
            bits = 8 * _codec(0, 0, data_type).STRUCT_TYPES[data_type].size
            low, high = ((-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if data_type in dt.SIGNED_TYPES
                         else (0, (1 << bits) - 1))
            if not low <= value <= high:
                raise ValueError(f'{value} is outside {name} range [{low}, {high}]')
        if data_type in dt.FLOAT_TYPES and not isinstance(value, (int, float)):
            raise ValueError(f'{value!r} is not a number')
        if data_type in (dt.VISIBLE_STRING, dt.UNICODE_STRING) and not isinstance(value, str):
            raise ValueError(f'{value!r} is not a string')
        return _codec(where.index, where.subindex, data_type).encode_raw(value)
    except (ValueError, TypeError, OverflowError, UnicodeError) as exc:
        raise SdoError(where, f'cannot encode as {name}: {exc}') from None


def decode(data_type: int, data: bytes, where: ObjectAddress) -> SdoPlain:
    """Value of ``data`` read as ``data_type``; SdoError on a length mismatch."""
    if data_type not in TYPE_NAMES:
        raise SdoError(where, f'unsupported data type code 0x{data_type:02X}')
    if data_type in (dt.OCTET_STRING, dt.DOMAIN):
        return bytes(data)
    var = _codec(where.index, where.subindex, data_type)
    size = var.STRUCT_TYPES[data_type].size if data_type in var.STRUCT_TYPES else None
    if size is not None and len(data) < size:
        raise SdoError(where, f'{len(data)} byte(s) received, {type_name(data_type)} needs {size}')
    try:
        value = var.decode_raw(bytes(data[:size] if size else data))
    except Exception as exc:  # canopen raises several types for malformed data
        raise SdoError(where, f'cannot decode {len(data)} byte(s) as {type_name(data_type)}: {exc}') from None
    if isinstance(value, bytearray):
        value = bytes(value)
    return bool(value) if data_type == dt.BOOLEAN else value


class SdoChannel:
    """The one path for SDO traffic to a node: a lock, retries on timeout, typed errors."""

    def __init__(self, node: canopen.RemoteNode, timeout: float, retries: int) -> None:
        self.node = node
        self.timeout = timeout
        self.retries = retries
        self._lock = threading.Lock()
        self.errors = 0
        self.last_error = ''
        node.sdo.RESPONSE_TIMEOUT = timeout

    def _where(self, index: int, subindex: int) -> ObjectAddress:
        return ObjectAddress(int(self.node.id or 0), index, subindex)

    def _run(self, action: Callable[[], _T], index: int, subindex: int, retry: bool = True) -> _T:
        where = self._where(index, subindex)
        attempts = 1 + max(0, self.retries) if retry else 1
        for attempt in range(1, attempts + 1):
            try:
                with self._lock:
                    return action()
            except SdoAbortedError as exc:
                error = SdoError(where, f'SDO abort 0x{exc.code:08X}: {abort_text(exc.code)}', exc.code)
                break
            except SdoCommunicationError as exc:
                error = SdoError(where, f'no valid SDO response ({exc}) after {attempt} attempt(s) '
                                        f'of {self.timeout * 1000:.0f} ms')
            except can.CanError as exc:
                error = SdoError(where, f'CAN error while sending SDO: {exc}')
                break
        self.errors += 1
        self.last_error = str(error)
        raise error

    def upload(self, index: int, subindex: int, retry: bool = True) -> bytes:
        """The object's bytes; ``retry=False`` for objects whose every access has an effect
        (a stream such as an ASCII channel, where a repeated request would skip data)."""
        return bytes(self._run(lambda: self.node.sdo.upload(index, subindex), index, subindex, retry))

    def download(self, index: int, subindex: int, data: bytes, retry: bool = True) -> None:
        self._run(lambda: self.node.sdo.download(index, subindex, data), index, subindex, retry)

    def od_type(self, index: int, subindex: int) -> int:
        """Data type of an object from the node's EDS; SdoError when it is not there."""
        return od_data_type(self.node.object_dictionary, int(self.node.id or 0), index, subindex)

    def read(self, index: int, subindex: int, data_type: int = AUTO) -> tuple[int, SdoPlain, bytes]:
        """(data type used, value, raw bytes) of one object."""
        data_type = data_type or self.od_type(index, subindex)
        raw = self.upload(index, subindex)
        return data_type, decode(data_type, raw, self._where(index, subindex)), raw

    def write(self, index: int, subindex: int, value: SdoPlain, data_type: int = AUTO) -> int:
        """Write one object; returns the data type used."""
        data_type = data_type or self.od_type(index, subindex)
        self.download(index, subindex, encode(data_type, value, self._where(index, subindex)))
        return data_type
