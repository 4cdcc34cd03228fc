"""Checking an axis' ``drive:`` settings that describe the mechanics between a motor and its
joint (gear ratio, direction, offset, metres per revolution), shared by the families whose
drives report their own units and so take no axis ``scaling``."""
from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from typing import Any


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def parse_drive_settings(options: Mapping[str, Any], family: str, keys: Collection[str],
                         booleans: Collection[str] = ()) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """(values, [(key, problem)]) of an axis' ``drive`` mapping: ``direction`` 1 or -1,
    ``offset`` any number, ``booleans`` true/false, every other key a number > 0."""
    values: dict[str, Any] = {}
    problems: list[tuple[str, str]] = []
    for key, raw in options.items():
        if key not in keys:
            problems.append((key, f"unknown key for family '{family}'; allowed keys: {', '.join(keys)}"))
            continue
        number = _number(raw)
        if key in booleans:
            if not isinstance(raw, bool):
                problems.append((key, f'expected true or false, got {raw!r}'))
            else:
                values[key] = raw
        elif key == 'direction':
            if number not in (1.0, -1.0):
                problems.append((key, f'expected 1 or -1, got {raw!r}'))
            else:
                values[key] = int(number or 1)
        elif key == 'offset':
            if number is None:
                problems.append((key, f'expected a number (rad or m), got {raw!r}'))
            else:
                values[key] = number
        elif number is None or number <= 0:
            problems.append((key, f'expected a number > 0, got {raw!r}'))
        else:
            values[key] = number
    return values, problems
