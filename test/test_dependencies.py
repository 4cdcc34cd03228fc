"""Every third-party import of drive_bridge/ is declared: in package.xml (by its rosdep key, or
named as having none) and in the install line of a colcon workspace (docs/hardware.md), so a
real Jazzy machine installs what the node imports at start."""
from __future__ import annotations

import ast
import importlib
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# Python packages: import name -> (rosdep key, pip distribution). The keys were looked up in
# ros/rosdistro's rosdep/python.yaml at commit 8468e88ccd523427f9131e39d2af0938f1c298b2; the
# `*-pip` keys install with pip; rosdistro has no key for the mcap Python package.
PYTHON = {
    'can': ('python3-can', 'python-can'),
    'canopen': ('canopen-pip', 'canopen'),
    'rosbags': ('python3-rosbags-pip', 'rosbags'),
    'mcap': (None, 'mcap'),
    'yaml': ('python3-yaml', 'PyYAML'),
    'numpy': ('python3-numpy', 'numpy'),
    'tqdm': ('python3-tqdm', 'tqdm'),
}
# declared although no module of drive_bridge/ imports them itself
RUNTIME_ONLY = {'lifecycle_msgs': 'rclpy.lifecycle, which the managed node uses'}


def third_party_imports() -> dict[str, set[str]]:
    """Top-level module -> the files of drive_bridge/ importing it (outside the standard library)."""
    found: dict[str, set[str]] = {}
    for path in sorted((REPO / 'drive_bridge').rglob('*.py')):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module else [])
            for name in names:
                top = name.split('.')[0]
                if top not in sys.stdlib_module_names and top not in ('__future__', 'drive_bridge'):
                    found.setdefault(top, set()).add(str(path.relative_to(REPO)))
    return found


def is_ros_package(module: str) -> bool:
    """Installed as a ROS package: share/<name>/package.xml beside its Python code's prefix
    (<prefix>/lib/pythonX.Y/site-packages/<name>)."""
    path = Path(importlib.import_module(module).__file__ or '').resolve()
    return (path.parents[4] / 'share' / module / 'package.xml').is_file()


def package_xml() -> tuple[set[str], set[str]]:
    """(exec_depend keys, names its 'no rosdep key (pip only): ...' comment gives)."""
    tree = ET.parse(REPO / 'package.xml', ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    depends = {e.text or '' for e in tree.getroot().iter('exec_depend')}
    comments = [c.text or '' for c in tree.getroot().iter(ET.Comment)]
    without = {n.strip() for c in comments if 'no rosdep key' in c for n in c.split(':', 1)[1].split(',')}
    return depends, without


def install_block() -> str:
    """The shell block of the docs that builds a colcon workspace."""
    for page in ('hardware.md', 'development.md'):
        path = REPO / 'docs' / page
        if path.is_file():
            for block in re.findall(r'```bash\n(.*?)```', path.read_text(), re.S):
                if 'colcon build' in block and 'pip install' in block:
                    return block
    raise AssertionError('no colcon install block (colcon build + pip install) in docs/hardware.md or development.md')


def test_every_import_of_the_package_is_in_package_xml() -> None:
    depends, without = package_xml()
    imports = third_party_imports()
    assert {'rclpy', 'canopen', 'can', 'control_msgs', 'mcap'} <= set(imports)  # the walk sees imports
    for module, files in sorted(imports.items()):
        where = f'{module} (imported by {", ".join(sorted(files)[:3])})'
        if module in PYTHON:
            key = PYTHON[module][0]
            assert (key in depends) if key else (module in without), f'{where}: declare {key or "it"} in package.xml'
        else:
            assert is_ros_package(module), f'{where}: neither a ROS package nor in PYTHON of this test'
            assert module in depends, f'{where}: add <exec_depend>{module}</exec_depend> to package.xml'
    # and nothing declared that the package does not use
    used = set(imports) | set(RUNTIME_ONLY) | {PYTHON[m][0] for m in imports if m in PYTHON}
    assert depends <= used, f'declared but not imported: {sorted(depends - used)}'
    assert without <= {m for m, (key, _) in PYTHON.items() if key is None}


def test_the_colcon_install_line_installs_what_rosdep_does_not() -> None:
    block = install_block()
    pip_line = next(line for line in block.splitlines() if line.startswith('pip install'))
    pinned = dict(re.findall(r'([A-Za-z0-9_.-]+)==([0-9][^\s]*)', pip_line))
    imports = third_party_imports()
    needed = {PYTHON[m][1] for m in imports if m in PYTHON and (PYTHON[m][0] is None or PYTHON[m][0].endswith('-pip'))}
    assert needed <= set(pinned), f'missing from the pip line: {sorted(needed - set(pinned))}'
    extra = set(pinned) - {dist for _, dist in PYTHON.values()}
    assert not extra, f'the pip line installs what the package does not import: {sorted(extra)}'
    # the versions the tests run with
    locked = dict(re.findall(r'^([A-Za-z0-9_.-]+)==(\S+)', (REPO / 'requirements.in').read_text(), re.M))
    assert pinned == {d: locked[d] for d in pinned}
    # rosdep installs the rest; the pip keys (which rosdep cannot install into Ubuntu 24.04's
    # Python) are skipped there and come from the pip line
    rosdep = next(line for line in block.splitlines() if line.startswith('rosdep install'))
    skipped = set(re.search(r'--skip-keys "([^"]*)"', rosdep).group(1).split())  # type: ignore[union-attr]
    assert skipped == {key for key, _ in PYTHON.values() if key and key.endswith('-pip')}
    assert '--from-paths src' in rosdep and 'colcon build --base-paths src src/drive_bridge/msg_defs' in block
