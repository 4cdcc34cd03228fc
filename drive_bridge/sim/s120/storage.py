"""Save and restore of the simulated S120 (0x1010 / 0x1011) [8.6]: sub 1 all, 2 the
communication objects, 3 the application (profile) objects, with the SINAMICS parameters of the
Control Unit and every drive object on the memory card. A partial save needs a full save first;
a restore takes effect at once (unlike CiA 301: not at the next reset)."""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.sim.s120.axis import S120Axis
from drive_bridge.sim.s120.objects import (
    ABORT_NOT_STORED,
    ERROR_HISTORY,
    RESTORE_PARAMETERS,
    SIGNATURE_LOAD,
    SIGNATURE_SAVE,
    STORE_PARAMETERS,
)
from drive_bridge.sim.s120.parameters import ParameterSet, profile_parameters
from drive_bridge.sim.store import ObjectStore

_RANGES = {1: ((0x1000, 0x1FFF), (0x6000, 0x9FFF)), 2: ((0x1000, 0x1FFF),), 3: ((0x6000, 0x9FFF),)}


class ParameterStorage:
    """The node's memory card; ``factory`` holds the object dictionary's factory values."""

    def __init__(self, store: ObjectStore, cu: ParameterSet, axes: Sequence[S120Axis],
                 reload_communication: Callable[[], None]) -> None:
        self._store = store
        self._cu = cu
        self._axes = axes
        self._reload_communication = reload_communication
        self._full_save_done = False
        self.factory: dict[int, Any] = {}

    def keep_factory(self) -> None:
        """The object dictionary as built is what a restore brings back."""
        self.factory = dict(self._store.defaults)

    def register(self, reg: Callable[..., None]) -> None:
        """0x1010:1..3 and 0x1011:1..3 through ``reg(index, subindex, **hooks)``."""
        for sub in (1, 2, 3):
            reg(STORE_PARAMETERS, sub, reader=lambda: 1, validator=lambda v, s=sub: self._check_save(s, v),
                on_write=lambda v, s=sub: self._save(s))
            reg(RESTORE_PARAMETERS, sub, reader=lambda: 1, validator=self._check_restore,
                on_write=lambda v, s=sub: self._restore(s))

    def _check_save(self, sub: int, value: int) -> None:
        if value != SIGNATURE_SAVE or (sub != 1 and not self._full_save_done):
            raise SdoAbortedError(ABORT_NOT_STORED)  # partial saves need a full save first

    @staticmethod
    def _check_restore(value: int) -> None:
        if value != SIGNATURE_LOAD:
            raise SdoAbortedError(ABORT_NOT_STORED)

    def _object_keys(self, sub: int) -> list[int]:
        """The stored objects a save / restore of ``sub`` covers (not process data, not computed)."""
        store = self._store
        keys = []
        for low, high in _RANGES[sub]:
            for k in store.keys_between(low, high):
                var = store.variables[k]
                if (k >> 8) in (0x1001, ERROR_HISTORY, STORE_PARAMETERS, RESTORE_PARAMETERS) \
                        or k in store.readers or (var.pdo_mappable and var.writable):
                    continue
                keys.append(k)
        return keys

    def _save(self, sub: int) -> None:
        for k in self._object_keys(sub):
            self._store.defaults[k] = self._store.values[k]
        if sub == 1:
            self._cu.save()
            for axis in self._axes:
                axis.parameters.save()
            self._full_save_done = True
        elif sub == 3:
            for axis in self._axes:
                axis.parameters.save(profile_parameters())

    def _restore(self, sub: int) -> None:
        for k in self._object_keys(sub):
            self._store.values[k] = self.factory[k]
        if sub == 1:
            self._cu.load_factory()
        for axis in self._axes:
            if sub != 2:
                axis.parameters.load_factory(None if sub == 1 else profile_parameters())
            axis.invalidate_parameters()
        if sub != 3:
            self._reload_communication()
