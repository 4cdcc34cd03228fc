"""COB-IDs of CiA 301's predefined connection set."""
from __future__ import annotations


def predefined_cob_id(kind: str, number: int, node_id: int) -> int:
    """COB-ID of PDO ``number`` (1..4) in CiA 301's predefined connection set."""
    if not 1 <= number <= 4:
        raise ValueError(f'{kind.upper()}{number} has no predefined COB-ID (only PDOs 1..4); give cob_id')
    base = 0x180 if kind == 'tpdo' else 0x200
    return base + 0x100 * (number - 1) + node_id
