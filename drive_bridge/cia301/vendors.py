"""CiA-assigned vendor IDs (object 0x1018:1) of drive makers seen in the field: a name for
the identity a node reports. An excerpt of CiA's register, from the makers' own EDS files."""
from __future__ import annotations

VENDOR_NAMES: dict[int, str] = {
    0x00000002: 'Beckhoff Automation',
    0x0000006A: 'Kollmorgen (Danaher Motion)',
    0x0000009A: 'Elmo Motion Control',
    0x000000AB: 'Copley Controls',
    0x000000BD: 'Kollmorgen',
    0x000000FB: 'maxon motor',
    0x00000147: 'Faulhaber',
    0x000001A3: 'Technosoft',
    0x0000026C: 'Nanotec Electronic',
    0x06000053: 'Siemens',
}


def vendor_name(vendor_id: int) -> str | None:
    """The maker's name for a vendor ID, or None when it is not in this excerpt."""
    return VENDOR_NAMES.get(vendor_id)
