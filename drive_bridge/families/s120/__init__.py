"""The SINAMICS S120 family (CBC10 CANopen): one node with up to 8 drive objects.

Modules: objects (indices, offsets, parameter numbers), eds (the vendor's modular or flat EDS
adapted to the configured slots), pdos (default map, COB-IDs of further drive objects, PDO
limits), boot (boot steps), units (drive units -> SI), options (the axis ``drive:`` settings),
emcy (fault numbers and drive objects), parameters (p/r numbers through the window 0x2000+ and
the selector p8630), driver (:class:`S120Quirks`: what its CiA 402 axis does differently), family
(:class:`SinamicsS120`, registered as ``sinamics_s120``).
"""
from drive_bridge.families.s120.driver import S120Quirks
from drive_bridge.families.s120.family import SinamicsS120

__all__ = ['S120Quirks', 'SinamicsS120']
