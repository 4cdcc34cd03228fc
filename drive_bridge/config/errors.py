"""ConfigError and the issue collector; EdsError, which the loader turns into an issue.

The loader gathers every problem of a file before raising, so one run shows the
user all of them; each issue carries the file and the path inside it.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import NamedTuple

from drive_bridge.errors import DriveBridgeError


class Issue(NamedTuple):
    """One problem: the file, the path inside it ('' = the whole file) and what is wrong."""

    file: str
    path: str
    message: str

    def __str__(self) -> str:
        return f'{self.file}: {self.path}: {self.message}' if self.path else f'{self.file}: {self.message}'


class ConfigError(DriveBridgeError, ValueError):
    """A configuration (or EDS) that cannot be used; ``issues`` lists every problem found."""

    def __init__(self, issues: Iterable[Issue]) -> None:
        self.issues: list[Issue] = list(issues)
        super().__init__('\n'.join(str(issue) for issue in self.issues))

    @classmethod
    def single(cls, file: str, path: str, message: str) -> ConfigError:
        return cls([Issue(file, path, message)])


class EdsError(DriveBridgeError):
    """Why an EDS/DCF cannot be used (the caller locates it)."""


@dataclass(frozen=True)
class Loc:
    """Where a value sits in the YAML: a dotted path plus, for keys inherited from
    ``defaults``, which node inherited them (the same line can be wrong for one node only)."""

    path: str = ''
    via: str = ''

    def key(self, key: object) -> Loc:
        return Loc(f'{self.path}.{key}' if self.path else str(key), self.via)

    def item(self, index: int) -> Loc:
        return Loc(f'{self.path}[{index}]', self.via)

    def __str__(self) -> str:
        return self.path


class Issues:
    """Collects errors and warnings of one file, in order and without repeats."""

    def __init__(self, file: str) -> None:
        self.file = file
        self.errors: list[Issue] = []
        self.warnings: list[Issue] = []

    def _issue(self, loc: Loc, message: str) -> Issue:
        if loc.via:
            message = f'{message} (inherited from defaults by {loc.via})'
        return Issue(self.file, loc.path, message)

    def error(self, loc: Loc, message: str) -> None:
        issue = self._issue(loc, message)
        if issue not in self.errors:
            self.errors.append(issue)

    def warn(self, loc: Loc, message: str) -> None:
        issue = self._issue(loc, message)
        if issue not in self.warnings:
            self.warnings.append(issue)

    @property
    def error_count(self) -> int:
        return len(self.errors)

    def raise_if_errors(self) -> None:
        if self.errors:
            raise ConfigError(self.errors)

    def warning_texts(self) -> tuple[str, ...]:
        return tuple(str(w) for w in self.warnings)
