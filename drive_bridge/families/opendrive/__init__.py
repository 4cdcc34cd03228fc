"""The OPEN drive family (CiA 301 only: RUN logic, CAN references, alarm word, P/C parameters).

Modules: objects (indices and numbers), options (the axis ``drive:`` settings), units (drive
units <-> SI), alarms (alarm names, EMCY), driver (the RUN-logic joint driver), parameters
(P/C by number with their format words), family (the :class:`OpenDrive` family, registered
as ``opendrive``).
"""
from drive_bridge.families.opendrive.driver import RunLogicDriver
from drive_bridge.families.opendrive.family import OpenDrive

__all__ = ['OpenDrive', 'RunLogicDriver']
