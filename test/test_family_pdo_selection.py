"""A family that selects predefined PDOs by number and whose TPDOs have no event-timer or
inhibit sub-index, registered through the public registry API: on the bus, the master writes
the selection object and the COB-ID / transmission type, never a mapping parameter
(0x16xx / 0x1Axx) and never a sub-index the family says does not exist; the node's process
data works with the selected PDOs."""
from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence
from pathlib import Path

import pytest

from akdtools import Sniffer
from bustools import config_from, running, unique_channel
from drive_bridge.families import (
    DriveFamily,
    PdoConfiguration,
    PdoTraits,
    get_family,
    register_family,
    unregister_family,
)
from drive_bridge.model import PdoConfig
from drive_bridge.sim import SimDrive402, register_simulator, registry as sim_registry

FAMILY = 'acme_library'
NODE = 11
RPDO_SELECT, TPDO_SELECT = 0x2600, 0x2A00  # one sub-index per PDO number: the library PDO chosen
SELECTION_OBJECTS = {RPDO_SELECT: 'RPDO', TPDO_SELECT: 'TPDO'}


def eds_with_selection(target: Path) -> Path:
    """The generic 402 EDS plus the two selection arrays (sub 1..4)."""
    text = Path(get_family('generic_402').eds_for(1)).read_text()
    sections = []
    for index, kind in SELECTION_OBJECTS.items():
        sections.append(f'[{index:04X}]\nParameterName={kind} selection\nSubNumber=0x5\nObjectType=0x8\n')
        sections.append(f'[{index:04X}sub0]\nParameterName=Number of entries\nObjectType=0x7\nDataType=0x0005\n'
                        'AccessType=ro\nDefaultValue=4\nPDOMapping=0\n')
        for sub in range(1, 5):
            sections.append(f'[{index:04X}sub{sub}]\nParameterName={kind}{sub} library number\nObjectType=0x7\n'
                            'DataType=0x0005\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n')
    text = text.replace('[ManufacturerObjects]\nSupportedObjects=0\n',
                        '[ManufacturerObjects]\nSupportedObjects=2\n1=0x2600\n2=0x2A00\n')
    target.write_text(text + '\n' + '\n'.join(sections))
    return target


class AcmeLibrary(DriveFamily):
    """PDOs chosen from the drive's library: library number = PDO number (the library's
    mappings are the generic 402 defaults); TPDOs have only sub-indices 1 and 2."""

    name = FAMILY
    pdo = PdoTraits(configuration=PdoConfiguration.SELECT_BY_NUMBER, comm_subindices=frozenset({1, 2}))

    def default_pdos(self, node_id: int, axes, synchronous: bool):  # type: ignore[no-untyped-def]
        return get_family('generic_402').default_pdos(node_id, axes, synchronous)

    def select_pdo(self, kind: str, config: PdoConfig) -> Sequence[tuple[int, int, int]]:
        index = RPDO_SELECT if kind == 'RPDO' else TPDO_SELECT
        return ((index, config.number, config.number),)


class SimAcmeLibrary(SimDrive402):
    """The drive side: a selection write is accepted and remembered."""

    def __init__(self, node, *, options=None):  # type: ignore[no-untyped-def]
        super().__init__(node, options=options)
        self.selected: dict[tuple[str, int], int] = {}
        for index, kind in SELECTION_OBJECTS.items():
            for sub in range(1, 5):
                self.register_object(index, sub, on_write=lambda value, k=kind, n=sub: self._select(k, n, value))

    def _select(self, kind: str, number: int, library: int) -> None:
        self.selected[(kind, number)] = library


@pytest.fixture
def family(tmp_path: Path) -> Iterator[Path]:
    register_family(AcmeLibrary)
    register_simulator(FAMILY)(SimAcmeLibrary)
    try:
        yield eds_with_selection(tmp_path / 'acme_library.eds')
    finally:
        unregister_family(FAMILY)
        sim_registry._SIMULATORS.pop(FAMILY, None)  # type: ignore[attr-defined]


def test_pdos_are_selected_by_number_and_only_existing_subindices_written(family: Path) -> None:
    channel = unique_channel('library')
    config = config_from({
        'bus': {'interface': 'virtual', 'channel': channel},
        'master': {'sync_period': 4000},
        'nodes': {'lib': {'node_id': NODE, 'family': FAMILY, 'dcf': str(family), 'axes': [{'joint': 'j'}]}},
    })
    sniffer = Sniffer(channel)
    try:
        with running(config) as (master, sim):
            writes = [struct.unpack_from('<HB', f.data, 1) for f in sniffer.frames(0x600 + NODE)
                      if f.data and f.data[0] >> 5 == 1]  # SDO download initiate: (index, subindex)
            drive = sim.drive(NODE)
            assert drive.selected == {('RPDO', n): n for n in (1, 2, 3)} | {('TPDO', n): n for n in (1, 2)}
            assert not [w for w in writes if 0x1600 <= w[0] <= 0x17FF or 0x1A00 <= w[0] <= 0x1BFF], \
                'a mapping parameter was written'
            tpdo_comm = {w for w in writes if 0x1800 <= w[0] <= 0x19FF}
            assert {(0x1800, 1), (0x1800, 2), (0x1801, 1), (0x1801, 2)} <= tpdo_comm
            assert not [w for w in tpdo_comm if w[1] not in (1, 2)], tpdo_comm
            axis = master.axes['j']
            axis.enable(timeout=2.0)  # the statusword arrives by the selected TPDO
            assert axis.feedback()[0]
    finally:
        sniffer.close()
