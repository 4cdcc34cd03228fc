"""The SDO server side of a simulated slave: canopen's SdoServer protocol with the
object access of the simulator.

canopen's LocalNode accepts any sub-index of an array (ODArray invents members on
lookup) and any sub-index of a plain variable, checks no value limits, and sends its
responses at once; here objects are looked up exactly (0x06020000 / 0x06090011),
access, length and EDS limits are checked (0x06010001/2, 0x06070010, 0x06090031/2),
and responses go through the slave (mute, delayed responses).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import canopen
from canopen.node.local import LocalNode
from canopen.objectdictionary import ObjectDictionary, datatypes as dt
from canopen.sdo.exceptions import SdoAbortedError
from canopen.sdo.server import SdoServer

from drive_bridge.sim.store import ObjectStore, key

ABORT_WRITE_ONLY = 0x06010001
ABORT_READ_ONLY = 0x06010002
ABORT_LENGTH = 0x06070010
ABORT_TOO_HIGH = 0x06090031
CONSUMER_HEARTBEAT = 0x1016
ABORT_TOO_LOW = 0x06090032

Reader = Callable[[int, int, bool], bytes]
Writer = Callable[[int, int, bytes, bool], None]


class SimSdoServer(SdoServer):
    """canopen's SDO server whose responses go to ``respond`` (the slave decides when)."""

    def __init__(self, node_id: int, node: LocalNode, respond: Callable[[bytes], None]) -> None:
        super().__init__(0x600 + node_id, 0x580 + node_id, node)
        self._respond = respond

    def send_response(self, response: bytes | bytearray) -> None:
        self._respond(bytes(response))


class SimLocalNode(LocalNode):
    """A LocalNode whose object access is the simulator's (typed store, checks, hooks).

    It subscribes nothing itself: the slave subscribes its own NMT-gated callbacks.
    """

    def __init__(self, node_id: int, od: ObjectDictionary, read: Reader, write: Writer,
                 respond: Callable[[bytes], None]) -> None:
        super().__init__(node_id, od)
        self._read = read
        self._write = write
        self.sdo = SimSdoServer(node_id, self, respond)

    def associate_network(self, network: canopen.Network) -> None:
        self.network = network
        for part in (self.sdo, self.tpdo, self.rpdo, self.nmt, self.emcy):
            part.network = network

    def remove_network(self) -> None:
        self.associate_network(canopen.network._UNINITIALIZED_NETWORK)

    def get_data(self, index: int, subindex: int, check_readable: bool = False) -> bytes:
        return self._read(index, subindex, check_readable)

    def set_data(self, index: int, subindex: int, data: bytes, check_writable: bool = False) -> None:
        self._write(index, subindex, data, check_writable)


def read_checked(store: ObjectStore, index: int, subindex: int, check_readable: bool) -> bytes:
    """The encoded present value, or the CiA 301 abort."""
    var = store.find(index, subindex)
    if check_readable and not var.readable:
        raise SdoAbortedError(ABORT_WRITE_ONLY)
    return store.encode(var, store.get(key(index, subindex)))


def decode_checked(store: ObjectStore, index: int, subindex: int, data: bytes, check_writable: bool) -> Any:
    """The value a download carries, after the access, length and EDS-limit checks."""
    var = store.find(index, subindex)
    if check_writable and not var.writable:
        raise SdoAbortedError(ABORT_READ_ONLY)
    if var.data_type in dt.NUMBER_TYPES and 8 * len(data) != len(var):
        raise SdoAbortedError(ABORT_LENGTH)
    value = store.decode(var, data)
    # 0x1016 entries follow CiA 301's layout (producer id in bits 16-23), whatever limit a file gives
    if var.data_type in dt.NUMBER_TYPES and not (index == CONSUMER_HEARTBEAT and subindex >= 1):
        if var.max is not None and value > var.max:
            raise SdoAbortedError(ABORT_TOO_HIGH)
        if var.min is not None and value < var.min:
            raise SdoAbortedError(ABORT_TOO_LOW)
    return value


def expedited_download_of(request: bytes, index: int, subindex: int) -> bool:
    """Whether ``request`` is an expedited download initiate for (index, subindex)."""
    return (len(request) == 8 and request[0] & 0xE2 == 0x22
            and int.from_bytes(request[1:3], 'little') == index and request[3] == subindex)
