"""Drive family name -> simulator class. Families with their own simulator register
here (``register_simulator``); the bus picks the class from ``node.family``."""
from __future__ import annotations

from collections.abc import Callable

from drive_bridge.sim.eds402 import EdsDrive402
from drive_bridge.sim.slave import SimulatedSlave

_SIMULATORS: dict[str, type[SimulatedSlave]] = {}


def register_simulator(family: str) -> Callable[[type[SimulatedSlave]], type[SimulatedSlave]]:
    """Class decorator: ``@register_simulator('akd')`` makes the class simulate that family."""
    def decorate(cls: type[SimulatedSlave]) -> type[SimulatedSlave]:
        _SIMULATORS[family] = cls
        return cls
    return decorate


def simulator_for(family: str) -> type[SimulatedSlave]:
    """The simulator class of a family; KeyError lists the simulated families."""
    try:
        return _SIMULATORS[family]
    except KeyError:
        raise KeyError(f'no simulator for drive family {family!r}; simulated: '
                       f'{", ".join(simulated_families())}') from None


def simulated_families() -> list[str]:
    return sorted(_SIMULATORS)


register_simulator('generic_402')(EdsDrive402)
register_simulator('generic_301')(SimulatedSlave)
