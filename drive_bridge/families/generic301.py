"""A CiA 301 node without CiA 402 (I/O modules, proxies): booted, monitored, SDO/PDO only."""
from __future__ import annotations

from drive_bridge.families.interface import DriveFamily, IdentityMatch
from drive_bridge.families.registry import register_family
from drive_bridge.families.traits import AxisTraits
from drive_bridge.model import Identity


@register_family
class Generic301(DriveFamily):
    """No axes and no default PDO map: the config gives the EDS and any PDOs."""

    name = 'generic_301'
    description = 'CiA 301 node without a drive profile (needs an EDS in the config)'
    axes = AxisTraits(has_cia402=False, max_count=0)

    def identity_match(self, identity: Identity, device_name: str) -> IdentityMatch:
        """Any CANopen node: the fallback when no family knows it."""
        return IdentityMatch.ANY
