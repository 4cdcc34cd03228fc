"""Rewrite the wheel build machine's Python paths in ROS wheels' CMake export files.

The ros-jazzy-* wheels ship ``share/*/cmake/*Export*.cmake`` files that name
``/opt/python/cpXY-cpXY/include/pythonX.Y`` and that interpreter's numpy include dir.
CMake's generate step refuses non-existent include paths, so a rosidl build in the
virtualenv fails until they point at this interpreter. Idempotent.
"""
from __future__ import annotations

import re
import sys
import sysconfig
from pathlib import Path

WHEEL_PYTHON = re.compile(r'/opt/python/cp\d+-cp\d+(?P<rest>/include/python[\d.]+|/lib/python[\d.]+/site-packages)')


def local_path(match: re.Match[str]) -> str:
    """Map one wheel build machine path to this interpreter's equivalent."""
    paths = sysconfig.get_paths()
    if match['rest'].startswith('/include/'):
        return paths['include']
    return paths['purelib']


def fix(prefix: Path) -> int:
    """Rewrite every CMake file under ``prefix/share``; return how many changed."""
    changed = 0
    for path in prefix.glob('share/*/cmake/*.cmake'):
        text = path.read_text()
        new = WHEEL_PYTHON.sub(local_path, text)
        if new != text:
            path.write_text(new)
            changed += 1
    return changed


if __name__ == '__main__':
    count = fix(Path(sys.argv[1]))
    if count:
        print(f'bootstrap: rewrote wheel build paths in {count} CMake files', file=sys.stderr)
