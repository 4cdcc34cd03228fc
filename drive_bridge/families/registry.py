"""Family name -> :class:`DriveFamily`: the built-in families plus any installed package's
entry points in the group ``drive_bridge.families`` (as python-can finds its interfaces), so
an integrator adds a family without editing this package::

    # pyproject.toml of the integrator's package
    [project.entry-points."drive_bridge.families"]
    my_drive = "my_package.family:MyDrive"

A family is a stateless description: :func:`get_family` makes one object per family name and
gives it to every caller in the process (the configuration, a scan, the master, the decoders);
what is learned of one node lives in the per-node part the family makes (``DriveFamily.node``).
"""
from __future__ import annotations

import logging
import threading
from importlib.metadata import entry_points

from drive_bridge.families.errors import FamilyError
from drive_bridge.families.interface import DriveFamily, IdentityMatch
from drive_bridge.families.traits import FLAT_TRAITS
from drive_bridge.model import Identity

ENTRY_POINT_GROUP = 'drive_bridge.families'
log = logging.getLogger('drive_bridge.families')

_REGISTRY: dict[str, type[DriveFamily]] = {}
_INSTANCES: dict[str, DriveFamily] = {}  # name -> the one object of the registered class
_instances_lock = threading.Lock()
_entry_points_loaded = False


def register_family(cls: type[DriveFamily]) -> type[DriveFamily]:
    """Class decorator adding a family to the registry under ``cls.name``."""
    if not (isinstance(cls, type) and issubclass(cls, DriveFamily)):
        raise FamilyError(f'{cls!r} is not a DriveFamily subclass')
    if not cls.name:
        raise FamilyError(f'{cls.__name__} has no name')
    flat = sorted({name for k in cls.__mro__ if issubclass(k, DriveFamily) and k is not DriveFamily
                   for name in vars(k) if name in FLAT_TRAITS})
    if flat:
        moved = '; '.join(f'{name}: set {FLAT_TRAITS[name]} instead' for name in flat)
        raise FamilyError(f'{cls.__name__} sets {moved} (the traits are records: drive_bridge.families.traits)')
    _REGISTRY[cls.name] = cls
    _INSTANCES.pop(cls.name, None)
    return cls


def unregister_family(name: str) -> None:
    """Remove a family (tests that register one of their own clean up with this)."""
    _REGISTRY.pop(name, None)
    _INSTANCES.pop(name, None)


def discover_families() -> list[str]:
    """Look for ``drive_bridge.families`` entry points again (a package installed since
    the first look); returns the known family names."""
    global _entry_points_loaded
    _entry_points_loaded = False
    return family_names()


def _load_entry_points() -> None:
    global _entry_points_loaded
    if _entry_points_loaded:
        return
    _entry_points_loaded = True
    for point in entry_points(group=ENTRY_POINT_GROUP):
        if point.name in _REGISTRY:
            continue
        try:
            cls = point.load()
            register_family(cls)
        except Exception as exc:  # one broken plugin must not hide the other families
            log.error('drive family entry point %r (%s) failed to load: %s', point.name, point.value, exc)
            continue
        if cls.name != point.name:
            _REGISTRY[point.name] = cls


def get_family(name: str) -> DriveFamily:
    """The family registered as ``name``, the same object on every call; FamilyError lists the
    known ones."""
    if name not in _REGISTRY:
        _load_entry_points()
    cls = _REGISTRY.get(name)
    if cls is None:
        raise FamilyError(f'unknown drive family {name!r}; known: {", ".join(family_names())}')
    with _instances_lock:
        family = _INSTANCES.get(name)
        if family is None or type(family) is not cls:  # none yet, or the name was registered again
            family = _INSTANCES[name] = cls()
    return family


def family_names() -> list[str]:
    _load_entry_points()
    return sorted(_REGISTRY)


def families_for_identity(identity: Identity, device_name: str = '') -> list[tuple[IdentityMatch, str]]:
    """The families that say a node with this identity may be theirs, surest first (ties by name)."""
    matches = [(get_family(name).identity_match(identity, device_name), name) for name in family_names()]
    return sorted((m for m in matches if m[0] is not IdentityMatch.NONE), key=lambda m: (-m[0], m[1]))
