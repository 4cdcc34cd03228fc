"""Drive families: data (EDS, default PDO maps, EMCY texts) plus small classes for what data
cannot say; the one boundary the core talks to. Look families up by name with
:func:`get_family`; add one with :func:`register_family` or the ``drive_bridge.families``
entry point group."""
from drive_bridge.families.errors import FamilyError
from drive_bridge.families.interface import DriveFamily, IdentityMatch, Liveness
from drive_bridge.families.node import FamilyNode
from drive_bridge.families.registry import (
    ENTRY_POINT_GROUP,
    discover_families,
    families_for_identity,
    family_names,
    get_family,
    register_family,
    unregister_family,
)
from drive_bridge.families.traits import (
    AxisTraits,
    BootDetection,
    BootTraits,
    ModeTraits,
    PdoConfiguration,
    PdoTraits,
)

# isort: split
# the built-in families register themselves on import
from drive_bridge.families import (
                                             akd as _akd,  # noqa: F401
                                             generic301 as _generic301,  # noqa: F401
                                             generic402 as _generic402,  # noqa: F401
                                             opendrive as _opendrive,  # noqa: F401
                                             s120 as _s120,  # noqa: F401
                                             servostar as _servostar,  # noqa: F401
)

__all__ = ['ENTRY_POINT_GROUP', 'AxisTraits', 'BootDetection', 'BootTraits', 'DriveFamily', 'FamilyError',
           'FamilyNode', 'IdentityMatch', 'Liveness', 'ModeTraits', 'PdoConfiguration', 'PdoTraits',
           'discover_families', 'families_for_identity', 'family_names', 'get_family', 'register_family',
           'unregister_family']
