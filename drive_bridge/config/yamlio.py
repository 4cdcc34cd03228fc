"""Reading YAML text strictly: syntax errors and duplicate keys name line and column.

PyYAML silently keeps the last of two equal keys (a second node 'left' would
replace the first) and reads ``1e-3`` as a string; both are fixed here.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from drive_bridge.config.errors import ConfigError


class _DuplicateKey(yaml.MarkedYAMLError):
    pass


class StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate keys and reads 1e-3 as a float."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, yaml.Node] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.get(key)
            except TypeError:  # unhashable key: let PyYAML report it
                continue
            if first is not None:
                raise _DuplicateKey(
                    None, None,
                    f'duplicate key {key!r} (first on line {first.start_mark.line + 1}); '
                    'a later key would silently replace the earlier one', key_node.start_mark)
            seen[key] = key_node
        return super().construct_mapping(node, deep=deep)


# YAML 1.1 needs a dot in a float ('1.0e-3'); accept what YAML 1.2 and every user expects.
StrictLoader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$'),
    list('-+0123456789'))


def parse_yaml(text: str, source: str) -> Any:
    """The YAML document in ``text``; ConfigError with line and column on bad syntax."""
    try:
        return yaml.load(text, Loader=StrictLoader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f'line {mark.line + 1}, column {mark.column + 1}' if mark else ''
        what = ' '.join(part for part in (exc.context, exc.problem) if part)
        kind = 'YAML error' if isinstance(exc, _DuplicateKey) else 'YAML syntax error'
        raise ConfigError.single(source, where, f'{kind}: {what}') from None
    except yaml.YAMLError as exc:
        raise ConfigError.single(source, '', f'YAML error: {exc}') from None


def read_yaml(path: Path, source: str) -> Any:
    """The YAML document in the file ``path``; a missing or unreadable file is a ConfigError."""
    try:
        text = path.read_text(encoding='utf-8')
    except FileNotFoundError:
        raise ConfigError.single(source, '', f'file not found (looked for {path.resolve()})') from None
    except IsADirectoryError:
        raise ConfigError.single(source, '', 'is a directory, expected a YAML file') from None
    except UnicodeDecodeError as exc:
        raise ConfigError.single(source, '', f'not UTF-8 text (byte {exc.object[exc.start]:#04x} '
                                             f'at offset {exc.start})') from None
    except OSError as exc:
        raise ConfigError.single(source, '', f'cannot be read: {exc.strerror or exc}') from None
    return parse_yaml(text, source)
