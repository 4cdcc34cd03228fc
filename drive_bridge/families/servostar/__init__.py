"""The SERVOSTAR 400/600 family (Kollmorgen, CANopen built in): one axis per node.

Modules: objects (indices, modes, bits), emcy (the manual's error table, categories, the
boot-up EMCY), pdos (library PDOs by number, free PDOs 37-40, the default set), boot (boot
steps: free PDOs, units, PTBASE), units (drive units -> SI), options (the axis ``drive:``
settings), parameters (ASCII parameters through the object channel 0x3500+), driver
(:class:`ServostarQuirks`: what its CiA 402 axis does differently), family (:class:`Servostar`,
registered as ``servostar``).
"""
from drive_bridge.families.servostar.driver import ServostarQuirks
from drive_bridge.families.servostar.family import Servostar

__all__ = ['Servostar', 'ServostarQuirks']
