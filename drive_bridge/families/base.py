"""The drive family interface and its registry."""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import ClassVar

from drive_bridge.model import AxisConfig, PdoConfig

DATA_DIR = Path(__file__).resolve().parent / 'data'


def predefined_cob_id(kind: str, number: int, node_id: int) -> int:
    """COB-ID of PDO ``number`` (1..4) in CiA 301's predefined connection set."""
    if not 1 <= number <= 4:
        raise ValueError(f'{kind.upper()}{number} has no predefined COB-ID (only PDOs 1..4); give cob_id')
    base = 0x180 if kind == 'tpdo' else 0x200
    return base + 0x100 * (number - 1) + node_id


class DriveFamily:
    """What the bridge knows about one line of drives beyond their EDS.

    Subclasses set the class attributes and override what differs; the core asks the
    family instead of testing vendor names.
    """

    name: ClassVar[str] = ''
    description: ClassVar[str] = ''
    default_eds: ClassVar[Path | None] = None  # shipped EDS used when the config names none
    has_cia402: ClassVar[bool] = True
    max_axes: ClassVar[int] = 1
    emcy_texts: ClassVar[Mapping[int, str]] = {}  # family-specific EMCY code texts
    pvt_submode: ClassVar[int | None] = None  # 0x60C0 code of cubic PVT interpolation, if any
    default_interpolation: ClassVar[str] = 'linear'  # 'linear' or 'pvt', for axes that do not say
    interpolation_fault_codes: ClassVar[frozenset[int]] = frozenset()  # EMCY: buffer underflow/overflow
    # modes the drive accepts, when its 0x6502 says otherwise (None: trust 0x6502)
    accepted_modes: ClassVar[frozenset[int] | None] = None
    # default of the axis keys mode / position_mode / velocity_mode / effort_mode, where they
    # differ from csp / csp / csv / cst
    default_modes: ClassVar[Mapping[str, str]] = {}

    def eds_for(self, axis_count: int) -> Path | None:
        """The shipped EDS for a node with ``axis_count`` axes (None: the config must name one)."""
        return self.default_eds

    def default_pdos(self, node_id: int, axes: Sequence[AxisConfig],
                     synchronous: bool) -> tuple[tuple[PdoConfig, ...], tuple[PdoConfig, ...]]:
        """(RPDOs, TPDOs) used when the config gives no mapping."""
        return (), ()


_REGISTRY: dict[str, type[DriveFamily]] = {}


def register_family(cls: type[DriveFamily]) -> type[DriveFamily]:
    """Class decorator adding a family to the registry under ``cls.name``."""
    if not cls.name:
        raise ValueError(f'{cls.__name__} has no name')
    _REGISTRY[cls.name] = cls
    return cls


def get_family(name: str) -> DriveFamily:
    """The family registered as ``name``; KeyError lists the known ones."""
    try:
        return _REGISTRY[name]()
    except KeyError:
        raise KeyError(f'unknown drive family {name!r}; known: {", ".join(family_names())}') from None


def family_names() -> list[str]:
    return sorted(_REGISTRY)
