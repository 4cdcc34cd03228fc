"""The ``ros`` and ``sim`` markers, given to each test by what its module uses.

``ros``: the module needs rclpy: it imports a ROS package or ``drive_bridge.ros`` (anywhere in
it), a helper module that does so at its top (rostools, nodebench), or a helper's function that
imports ROS inside (faulttools.demo_bridge); a test that takes the ``ros`` fixture is marked by
the conftest. ``sim``: the module runs simulated drives: it imports ``drive_bridge.sim``, or a
helper's function or class that uses it (bustools.running, not bustools.unique_channel).
Read from the source with ``ast``, so that choosing tests imports nothing.
"""
from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROS_MODULES = ('rclpy', 'drive_bridge.ros', 'drive_bridge_interfaces', 'rosbag2_py', 'launch', 'launch_ros',
               'builtin_interfaces', 'rcl_interfaces', 'lifecycle_msgs', 'action_msgs', 'control_msgs')
SIM_MODULES = ('drive_bridge.sim',)
Imports = list[tuple[str, list[str]]]  # (module, the names imported from it)


def _under(module: str, prefixes: tuple[str, ...]) -> bool:
    return any(module == p or module.startswith(p + '.') for p in prefixes)


def _imports(tree: ast.AST) -> Imports:
    found: Imports = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, [alias.asname or alias.name]) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.append((node.module, [alias.name for alias in node.names]))
    return found


def _kinds(imports: Imports) -> frozenset[str]:
    """What a piece of code that makes these imports uses."""
    kinds: set[str] = set()
    for module, names in imports:
        if _under(module, ROS_MODULES) or module.split('.')[0].endswith('_msgs'):
            kinds.add('ros')
        if _under(module, SIM_MODULES):
            kinds.add('sim')
        helper = _helper(module) if '.' not in module else None
        if helper is not None:
            on_import, by_name = helper
            kinds |= on_import
            for name in names:
                kinds |= by_name.get(name, frozenset())
    return frozenset(kinds)


@cache
def _helper(name: str) -> tuple[frozenset[str], dict[str, frozenset[str]]] | None:
    """A helper module of this directory: what importing it needs (ROS imported at its top), and
    what each of its top-level names uses. None when ``name`` is not one."""
    path = HERE / f'{name}.py'
    if not path.is_file() or name == 'conftest':
        return None
    tree = ast.parse(path.read_text(encoding='utf-8'))
    top: Imports = _imports(ast.Module(body=[n for n in tree.body if isinstance(n, ast.Import | ast.ImportFrom)],
                                       type_ignores=[]))
    by_name: dict[str, frozenset[str]] = {}
    for module, names in top:  # an imported name uses what its source uses
        for imported in names:
            by_name[imported] = _kinds([(module, [imported])])
    defs = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef | ast.ClassDef)}
    for name, node in defs.items():
        by_name[name] = _kinds(_imports(node))
    changed = True
    while changed:  # a definition uses what the names it refers to use
        changed = False
        for name, node in defs.items():
            used = set(by_name[name])
            for ref in ast.walk(node):
                if isinstance(ref, ast.Name) and ref.id != name:
                    used |= by_name.get(ref.id, frozenset())
            if used != by_name[name]:
                by_name[name], changed = frozenset(used), True
    return frozenset({'ros'} & _kinds(top)), by_name


@cache
def module_kinds(path: Path) -> frozenset[str]:
    """'ros' and/or 'sim' for the test module at ``path``."""
    return _kinds(_imports(ast.parse(path.read_text(encoding='utf-8'))))
