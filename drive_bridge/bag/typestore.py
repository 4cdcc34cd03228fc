"""The message types a bag of this package uses: ROS 2 Jazzy plus drive_bridge_interfaces.

The package's own types are registered from their ``.msg`` files (the installed share
directory, else the checkout's ``msg_defs/``), so bags decode without rclpy or a built
workspace and the message definitions written into a bag are the ones ROS builds.
"""
from __future__ import annotations

import functools
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from drive_bridge.bag.errors import BagError

INTERFACES = 'drive_bridge_interfaces'


def msg_dirs() -> list[Path]:
    """Where the interface package's ``.msg`` files may be: installed share dir, then the checkout."""
    return [Path(sys.prefix) / 'share' / INTERFACES / 'msg',
            Path(__file__).resolve().parents[2] / 'msg_defs' / 'msg']


def _msg_dir() -> Path:
    for directory in msg_dirs():
        if any(directory.glob('*.msg')):
            return directory
    raise BagError(f'no {INTERFACES} .msg files found in: {", ".join(str(d) for d in msg_dirs())}')


@functools.cache
def typestore() -> Typestore:
    """ROS 2 Jazzy types + the ``drive_bridge_interfaces`` msg types (cached)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types = {}
    for path in sorted(_msg_dir().glob('*.msg')):
        types.update(get_types_from_msg(path.read_text(encoding='utf-8'), f'{INTERFACES}/msg/{path.stem}'))
    store.register(types)
    return store
