"""The Kollmorgen AKD family (CiA 402 with PVT; ASCII parameters over object 0x2026).

Modules: parameters (the ASCII parameter table and its access), family (:class:`Akd`,
registered as ``akd``); data/ holds akd.eds and the ASCII table the simulator reads too.
"""
from drive_bridge.families.akd.family import Akd

__all__ = ['Akd']
