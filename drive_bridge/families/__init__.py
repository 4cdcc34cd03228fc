"""Drive families: data (EDS, default PDO maps, EMCY texts) plus small classes for what
data cannot say. Look families up by name with :func:`get_family`."""
from drive_bridge.families.base import DriveFamily, family_names, get_family, register_family
from drive_bridge.families import generic301 as _generic301, generic402 as _generic402  # noqa: F401  (register themselves)
from drive_bridge.families import akd as _akd  # noqa: F401,E402  (registers itself)

__all__ = ['DriveFamily', 'family_names', 'get_family', 'register_family']
