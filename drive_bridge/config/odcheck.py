"""Questions the loader asks an object dictionary: does an object exist, may it be
written or mapped, does a value fit its data type. Answers are messages, so every
caller words its errors the same way."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from canopen import ObjectDictionary
from canopen.objectdictionary import ODArray, ODRecord, ODVariable, datatypes as dt

from drive_bridge.cia402 import objects as cia402
from drive_bridge.config.reader import describe, parse_int_text
from drive_bridge.model import SdoScalar

TYPE_NAMES: dict[int, str] = {value: name for name, value in vars(dt).items()
                              if name.isupper() and isinstance(value, int)}

# Size of each fixed-size type in a PDO (CiA 301: BOOLEAN takes one bit).
TYPE_BITS: dict[int, int] = {dt.BOOLEAN: 1, dt.REAL32: 32, dt.REAL64: 64}
for _code, _name in TYPE_NAMES.items():
    for _prefix in ('INTEGER', 'UNSIGNED'):
        if _name.startswith(_prefix) and _name[len(_prefix):].isdigit():
            TYPE_BITS[_code] = int(_name[len(_prefix):])

# Well-known CiA 402 names for objects a file may lack (so 'not in X.eds' still says what it is).
_KNOWN_402: dict[int, str] = {value: name.lower().replace('_', ' ') + (' value' if name.endswith('_ACTUAL') else '')
                              for name, value in vars(cia402).items()
                              if name.isupper() and isinstance(value, int) and 0x6000 <= value < 0x6800}
_REAL32_MAX = 3.4028234663852886e38


def hex_index(index: int) -> str:
    """'0x607A': object indices as CiA documents print them."""
    return f'0x{index:04X}'


def hex_cob(cob_id: int) -> str:
    return f'0x{cob_id:03X}'


def type_name(code: int | None) -> str:
    return TYPE_NAMES.get(code or -1, f'data type {code:#x}' if code is not None else 'no data type')


def known_name(index: int) -> str:
    """'statusword (axis slot 1)' for 0x6841; '' for objects outside CiA 402."""
    for slot in range(cia402.MAX_AXES):
        name = _KNOWN_402.get(index - slot * cia402.AXIS_OFFSET)
        if name:
            return f'{name} (axis slot {slot})' if slot else name
    return ''


def ref(index: int, subindex: int, name: str = '') -> str:
    """'0x6077:00 'Torque actual value'' as used in every message."""
    text = f'object {hex_index(index)}:{subindex:02X}'
    return f"{text} '{name}'" if name else text


def var_ref(var: ODVariable) -> str:
    return ref(var.index, var.subindex, var.qualname)


@dataclass(frozen=True)
class Lookup:
    """The variable at index:subindex, or why there is none."""

    var: ODVariable | None
    problem: str = ''


def lookup(od: ObjectDictionary, eds_name: str, index: int, subindex: int) -> Lookup:
    obj = od.get(index)
    if obj is None:
        known = known_name(index)
        label = ref(index, subindex) + (f' ({known})' if known else '')
        return Lookup(None, f'{label} is not in {eds_name}')
    if isinstance(obj, ODVariable):
        if subindex != 0:
            return Lookup(None, f"{ref(index, subindex)}: {hex_index(index)} '{obj.name}' is a plain variable "
                                f'in {eds_name}; use sub-index 0')
        return Lookup(obj)
    assert isinstance(obj, (ODRecord, ODArray))
    var = obj.subindices.get(subindex)
    if var is None:
        subs = ', '.join(str(s) for s in sorted(obj.subindices)) or 'none'
        return Lookup(None, f"{ref(index, subindex)}: {hex_index(index)} '{obj.name}' has no sub-index {subindex} "
                            f'in {eds_name} (it has {subs})')
    return Lookup(var)


def is_writable(var: ODVariable) -> bool:
    return 'w' in var.access_type  # rw, wo, rww, rwr


def is_readable(var: ODVariable) -> bool:
    return 'r' in var.access_type or var.access_type == 'const'


def pdo_bits(var: ODVariable) -> int | None:
    """Bits the variable takes in a PDO; None for types without a fixed size."""
    return TYPE_BITS.get(var.data_type or -1)


def int_range(code: int) -> tuple[int, int] | None:
    bits = TYPE_BITS.get(code)
    if bits is None or code in (dt.BOOLEAN, dt.REAL32, dt.REAL64):
        return None
    if code in dt.SIGNED_TYPES:
        return -(1 << (bits - 1)), (1 << (bits - 1)) - 1
    return 0, (1 << bits) - 1


def _octets(value: Any) -> bytes | None:
    if isinstance(value, str):
        text = value.strip()
        text = text[2:] if text.lower().startswith('0x') else text
        try:
            return bytes.fromhex(text)
        except ValueError:
            return None
    if isinstance(value, list) and all(isinstance(b, int) and not isinstance(b, bool) and 0 <= b <= 255
                                       for b in value):
        return bytes(value)
    return None


def convert_value(var: ODVariable, value: Any, eds_name: str) -> tuple[SdoScalar | None, str]:
    """``value`` converted to what an SDO download of ``var`` takes, or (None, message)."""
    code = var.data_type
    tname = type_name(code)
    got = describe(value)
    if code == dt.BOOLEAN:
        if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
            return bool(value), ''
        return None, f'expected true or false ({tname}), got {got}'
    bounds = int_range(code) if code is not None else None
    if bounds is not None:
        lo, hi = bounds
        narrowed = []
        if isinstance(var.min, int) and var.min > lo:
            lo = var.min
            narrowed.append('LowLimit')
        if isinstance(var.max, int) and var.max < hi:
            hi = var.max
            narrowed.append('HighLimit')
        limits = f', {" and ".join(narrowed)} in {eds_name}' if narrowed else ''
        number = parse_int_text(value, allow_str=True)
        if number is None or not lo <= number <= hi:
            return None, f'expected an integer {lo}..{hi} ({tname}{limits}), got {got}'
        return number, ''
    if code in (dt.REAL32, dt.REAL64):
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) \
                and (code == dt.REAL64 or abs(value) <= _REAL32_MAX):
            return float(value), ''
        return None, f'expected a number ({tname}), got {got}'
    if code in (dt.VISIBLE_STRING, dt.UNICODE_STRING):
        if isinstance(value, str):
            return value, ''
        return None, f'expected a string ({tname}), got {got}'
    if code in (dt.OCTET_STRING, dt.DOMAIN):
        octets = _octets(value)
        if octets is None:
            return None, f"expected bytes as a hex string ('0A 1B FF') or a list of 0..255 ({tname}), got {got}"
        return octets, ''
    return None, f'{tname} values cannot be written at boot by drive_bridge'
