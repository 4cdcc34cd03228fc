"""Loading EDS/DCF files robustly: vendor files come in odd encodings.

The text is decoded here instead of by ``open()`` so the result does not depend on
the locale: a UTF-8 BOM (Siemens' SINAMICS S120 V4.8 file) is dropped, and a file
that is not UTF-8 (a CP437 byte in a FAULHABER file) is read as Latin-1, which
maps every byte and keeps the ASCII that an EDS is made of.
"""
from __future__ import annotations

import io
import logging
import os
from pathlib import Path

import canopen
from canopen import ObjectDictionary

from drive_bridge.config.errors import ConfigError, EdsError

SUFFIXES = ('.eds', '.dcf')
_UTF8_BOM = b'\xef\xbb\xbf'


class _Collect(logging.Handler):
    """Keeps canopen's warnings about a file so the loader can report them as warnings."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def _decode(path: Path, data: bytes) -> tuple[str, list[str]]:
    if data.startswith(_UTF8_BOM):
        return data.decode('utf-8-sig', errors='replace'), []
    try:
        return data.decode('utf-8'), []
    except UnicodeDecodeError as exc:
        note = (f'{path.name} is not UTF-8 (byte {data[exc.start]:#04x} at offset {exc.start}); '
                'read as Latin-1')
        return data.decode('latin-1'), [note]


def read_object_dictionary(path: Path, node_id: int | None) -> tuple[ObjectDictionary, list[str]]:
    """The object dictionary of an EDS/DCF with ``$NODEID`` resolved for ``node_id``, and
    warnings about the file (encoding fallback, objects canopen skipped).

    Raises EdsError with the reason when the file is missing, not an EDS/DCF or empty.
    """
    if path.suffix.lower() not in SUFFIXES:
        raise EdsError(f'{path.name} is not an EDS/DCF file (expected the extension .eds or .dcf)')
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise EdsError(f'file not found (looked for {path.resolve()})') from None
    except IsADirectoryError:
        raise EdsError(f'{path} is a directory, expected an EDS/DCF file') from None
    except OSError as exc:
        raise EdsError(f'{path.name} cannot be read: {exc.strerror or exc}') from None
    text, notes = _decode(path, data)
    source = io.StringIO(text)
    source.name = str(path)  # import_od picks the format from the name
    collect = _Collect()
    logger = logging.getLogger('canopen.objectdictionary')
    logger.addHandler(collect)
    try:
        od = canopen.import_od(source, node_id)
    except Exception as exc:  # configparser, ObjectDictionaryError, ValueError...: all mean "bad file"
        reason = ' '.join(str(exc).replace(str(path), path.name).split())
        raise EdsError(f'{path.name} is not a readable EDS/DCF: {type(exc).__name__}: {reason}') from None
    finally:
        logger.removeHandler(collect)
    if len(od) == 0:
        raise EdsError(f'{path.name} defines no objects (is it an EDS/DCF?)')
    if collect.messages:
        notes.append(f'{path.name}: canopen: {"; ".join(collect.messages)}')
    return od, notes


def load_object_dictionary(path: str | os.PathLike[str], node_id: int | None) -> ObjectDictionary:
    """The object dictionary of the EDS/DCF at ``path`` for node ``node_id``.

    Raises ConfigError naming the file and the reason when it cannot be used.
    """
    try:
        od, _ = read_object_dictionary(Path(path), node_id)
    except EdsError as exc:
        raise ConfigError.single(str(path), '', str(exc)) from None
    return od
