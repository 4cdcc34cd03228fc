"""CiA 301 rules for writes to the communication objects a simulated slave refuses
(abort 0x06090030 unless said otherwise): kept apart from the slave so each rule is one
small function a validator calls."""
from __future__ import annotations

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.nmt import check_consumer_entries
from drive_bridge.sim.store import ObjectStore

ABORT_INVALID_VALUE = 0x06090030
COB_ID_SYNC = 0x1005
CYCLE_PERIOD = 0x1006
CONSUMER_HEARTBEAT = 0x1016
PRODUCER_HEARTBEAT = 0x1017
IDENTITY = 0x1018


def check_history_write(value: int) -> None:
    """0x1003:0: only 0 (clear the history) may be written."""
    if value != 0:
        raise SdoAbortedError(ABORT_INVALID_VALUE)


def check_sync_cob(value: int) -> None:
    """0x1005: this device cannot produce SYNC; 11-bit ids only."""
    if value & (1 << 30) or value & (1 << 29):
        raise SdoAbortedError(ABORT_INVALID_VALUE)


def check_emcy_cob(old: int, value: int) -> None:
    """0x1014: 11-bit ids only; the id changes only while the EMCY is invalid (bit 31)."""
    if value & (1 << 29):
        raise SdoAbortedError(ABORT_INVALID_VALUE)
    if not old & (1 << 31) and not value & (1 << 31) and (old ^ value) & 0x1FFFFFFF:
        raise SdoAbortedError(ABORT_INVALID_VALUE)


def check_consumer_write(store: ObjectStore, sub: int, value: int) -> None:
    """0x1016:sub: two active entries for one producer abort with 0x06040043."""
    entries = {k & 0xFF: store.values[k] for k in store.keys_between(CONSUMER_HEARTBEAT, CONSUMER_HEARTBEAT)
               if k & 0xFF}
    entries[sub] = value
    check_consumer_entries(entries)
