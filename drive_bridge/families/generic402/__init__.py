"""Any drive that follows CiA 402 (the default family): its default process data is fitted
to the drive's EDS (:mod:`.pdomap`), and an axis that names no mode gets the best streaming
mode the drive's 0x6502 has (:mod:`.modes`).

Modules: family (:class:`Generic402`, registered as ``generic_402``), pdomap, modes, eds (the
EDS reading those use), edsgen (the shipped EDS files in data/)."""
from drive_bridge.families.generic402.family import Generic402

__all__ = ['Generic402']
