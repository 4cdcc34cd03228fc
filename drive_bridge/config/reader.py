"""Typed access to parsed YAML that records a located issue instead of raising.

Getters return the default after recording an error, so the loader keeps going and
reports every problem of a file in one run; the final ConfigError makes the
placeholder values unobservable.
"""
from __future__ import annotations

import difflib
import math
from collections.abc import Collection, Iterator, Mapping
from typing import Any

from drive_bridge.config.errors import Issues, Loc


def describe(value: Any) -> str:
    """A value as the user wrote it in YAML (for 'got ...' in messages)."""
    if value is None:
        return 'null (no value)'
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, Mapping):
        return 'a mapping'
    if isinstance(value, (list, tuple)):
        return 'a list'
    if isinstance(value, str):
        return repr(value)
    return str(value)


def suggestion(word: str, choices: Collection[str]) -> str:
    """" (did you mean 'x'?)" for the closest choice, '' when nothing is close."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ''


def _range_text(lo: float | None, hi: float | None, gt: float | None = None) -> str:
    if gt is not None:
        return f' > {gt:g}'
    if lo is not None and hi is not None:
        return f' {lo}..{hi}'
    if lo is not None:
        return f' >= {lo}'
    if hi is not None:
        return f' <= {hi}'
    return ''


def parse_int_text(value: Any, allow_str: bool) -> int | None:
    """An int from an int or (if allowed) a string like '0x9A' or '42'; None otherwise."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if allow_str and isinstance(value, str):
        try:
            return int(value.strip(), 0)
        except ValueError:
            return None
    return None


def to_int(issues: Issues, value: Any, loc: Loc, *, lo: int | None = None, hi: int | None = None,
           allow_str: bool = False) -> int | None:
    """An integer within [lo, hi]; hex strings only where CANopen people write them."""
    number = parse_int_text(value, allow_str)
    if number is None or (lo is not None and number < lo) or (hi is not None and number > hi):
        issues.error(loc, f'expected an integer{_range_text(lo, hi)}, got {describe(value)}')
        return None
    return number


def to_number(issues: Issues, value: Any, loc: Loc, *, gt: float | None = None,
              ge: float | None = None, nonzero: bool = False) -> float | None:
    """A finite int or float, optionally bounded."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok and ((gt is not None and value <= gt) or (ge is not None and value < ge) or (nonzero and value == 0)):
        ok = False
    if not ok:
        bound = _range_text(ge, None, gt) or (' other than 0' if nonzero else '')
        issues.error(loc, f'expected a number{bound}, got {describe(value)}')
        return None
    return float(value)


def to_bool(issues: Issues, value: Any, loc: Loc) -> bool | None:
    if not isinstance(value, bool):
        issues.error(loc, f'expected true or false, got {describe(value)}')
        return None
    return value


def to_str(issues: Issues, value: Any, loc: Loc, *, choices: Collection[str] = ()) -> str | None:
    """A non-empty string, optionally one of ``choices`` (with a suggestion when not)."""
    if not isinstance(value, str) or not value:
        issues.error(loc, f'expected a non-empty string, got {describe(value)}')
        return None
    if choices and value not in choices:
        listed = ', '.join(f"'{c}'" for c in choices)
        issues.error(loc, f'expected one of {listed}, got {describe(value)}{suggestion(value, choices)}')
        return None
    return value


class Section:
    """A YAML mapping plus the location of each key (keys may come from ``defaults``)."""

    def __init__(self, issues: Issues, data: Mapping[str, Any], loc: Loc,
                 locs: Mapping[str, Loc] | None = None, inherited: Collection[str] = ()) -> None:
        self.issues = issues
        self.data = dict(data)
        self.where = loc
        self._locs = dict(locs or {})
        self.inherited = frozenset(inherited)

    @classmethod
    def of(cls, issues: Issues, value: Any, loc: Loc, what: str = 'a mapping') -> Section | None:
        """A section from a YAML value: null is an empty section, anything but a mapping
        with string keys is an error (None returned)."""
        if value is None:
            return cls(issues, {}, loc)
        if not isinstance(value, Mapping):
            issues.error(loc, f'expected {what}, got {describe(value)}')
            return None
        good: dict[str, Any] = {}
        for key, item in value.items():
            if isinstance(key, str):
                good[key] = item
            else:
                issues.error(loc.key(describe(key)), f'expected a string key, got {describe(key)}')
        return cls(issues, good, loc)

    @classmethod
    def merged(cls, own: Section, defaults: Section | None, via: str) -> Section:
        """``own`` over ``defaults``: a node's key replaces the default's whole value."""
        if defaults is None:
            return own
        data = dict(defaults.data)
        locs = {k: Loc(defaults.loc(k).path, via) for k in defaults.data}
        inherited = set(defaults.data) - set(own.data)
        data.update(own.data)
        locs.update({k: own.loc(k) for k in own.data})
        return cls(own.issues, data, own.where, locs, inherited)

    def __contains__(self, key: str) -> bool:
        return key in self.data

    def __iter__(self) -> Iterator[str]:
        return iter(self.data)

    def get(self, key: str, default: Any = None) -> Any:
        return self.data.get(key, default)

    def loc(self, key: str) -> Loc:
        return self._locs.get(key) or self.where.key(key)

    def own(self, key: str) -> bool:
        """The key is in this section itself (not inherited from ``defaults``)."""
        return key in self.data and key not in self.inherited

    def check_keys(self, allowed: Collection[str], ignored: Mapping[str, str] | None = None,
                   hints: Mapping[str, str] | None = None) -> None:
        """Unknown keys are errors naming the allowed ones; ``ignored`` keys (other tools')
        are warnings with their reason; ``hints`` give a specific message for a key."""
        ignored = ignored or {}
        hints = hints or {}
        for key in self.data:
            if key in allowed:
                continue
            if key in ignored:
                self.issues.warn(self.loc(key), f'ignored: {ignored[key]}')
            elif key in hints:
                self.issues.error(self.loc(key), hints[key])
            else:
                listed = ', '.join(sorted(allowed))
                self.issues.error(self.loc(key), f'unknown key{suggestion(key, allowed)}; allowed keys: {listed}')

    def require(self, key: str, what: str) -> bool:
        if key in self.data:
            return True
        self.issues.error(self.where.key(key), f'required key is missing; expected {what}')
        return False

    def section(self, key: str, what: str = 'a mapping') -> Section | None:
        """The sub-mapping at ``key``; None if absent or invalid."""
        if key not in self.data:
            return None
        return Section.of(self.issues, self.data[key], self.loc(key), what)

    def get_int(self, key: str, default: int | None = None, **bounds: Any) -> int | None:
        if key not in self.data:
            return default
        value = to_int(self.issues, self.data[key], self.loc(key), **bounds)
        return default if value is None else value

    def get_number(self, key: str, default: float | None = None, **bounds: Any) -> float | None:
        if key not in self.data:
            return default
        value = to_number(self.issues, self.data[key], self.loc(key), **bounds)
        return default if value is None else value

    def get_bool(self, key: str, default: bool) -> bool:
        if key not in self.data:
            return default
        value = to_bool(self.issues, self.data[key], self.loc(key))
        return default if value is None else value

    def get_str(self, key: str, default: str | None = None, choices: Collection[str] = ()) -> str | None:
        if key not in self.data:
            return default
        value = to_str(self.issues, self.data[key], self.loc(key), choices=choices)
        return default if value is None else value

    def get_list(self, key: str, what: str = 'a list') -> list[tuple[Loc, Any]] | None:
        """(location, item) pairs of the list at ``key`` (null: empty); None if absent or not a list."""
        if key not in self.data:
            return None
        value = self.data[key]
        if value is None:
            return []
        if not isinstance(value, list):
            self.issues.error(self.loc(key), f'expected {what}, got {describe(value)}')
            return None
        return [(self.loc(key).item(i), item) for i, item in enumerate(value)]
