"""Print the pinned lock of the installed distributions (for requirements.txt).

Only real wheels (``*.dist-info``) are listed: the ROS wheels also carry ``*.egg-info``
records of their inner packages (``action_msgs``, ``rclpy``...), which are not on PyPI.
"""
from __future__ import annotations

from importlib import metadata

SKIP = {'drive-bridge', 'drive_bridge', 'pip'}


def lock_lines() -> list[str]:
    """Return ``name==version`` for every installed wheel, sorted case-insensitively."""
    lines = set()
    for dist in metadata.distributions():
        path = getattr(dist, '_path', None)
        name = dist.metadata['Name']
        if path is None or not str(path).endswith('.dist-info') or name in SKIP:
            continue
        lines.add(f'{name}=={dist.version}')
    return sorted(lines, key=str.lower)


if __name__ == '__main__':
    print('# Full pinned lock of requirements.in. Regenerate with: tools/bootstrap.sh --relock')
    print('\n'.join(lock_lines()))
