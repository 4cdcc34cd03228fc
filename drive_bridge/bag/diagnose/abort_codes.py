"""SDO abort code texts: canopen's CiA 301 table (as ``standard_objects`` holds it, so that an
abort does not import canopen), with a short reading of the usual causes."""
from __future__ import annotations

from drive_bridge.bag.diagnose.standard_objects import ABORT_TEXTS

# what a person should check when the drive answers with this code (probable cause)
_HINTS = {
    0x05040000: 'the server did not answer in time',
    0x06010002: 'the object is read-only',
    0x06010001: 'the object is write-only',
    0x06020000: 'the drive has no such object (wrong EDS or firmware)',
    0x06090011: 'the drive has no such subindex (wrong EDS or firmware)',
    0x06040041: 'that object cannot be mapped into a PDO',
    0x06040042: 'the PDO mapping is longer than 64 bits',
    0x06070010: 'the value has the wrong size for the object',
    0x06090030: 'value range: the value is outside what the drive accepts',
    0x06090031: 'the value is above the drive\'s maximum',
    0x06090032: 'the value is below the drive\'s minimum',
    0x08000022: 'the drive refuses it in its present state (e.g. while enabled or not pre-operational)',
    0x08000021: 'the drive is under local control',
}


def abort_text(code: int) -> str:
    """'Value range of parameter exceeded' for 0x06090030; names unknown codes."""
    return ABORT_TEXTS.get(code, f'unknown abort code 0x{code:08X}')


def abort_cause(code: int) -> str:
    return _HINTS.get(code, abort_text(code).lower())
