"""What a family module takes from the core, read from its classes and its source: which core
classes it subclasses, which private members of core classes it touches (test_layering.py)."""
from __future__ import annotations

import ast
import functools
import importlib
import importlib.util
import inspect
import pkgutil
from collections.abc import Iterator
from pathlib import Path

PACKAGE = 'drive_bridge'
PACKAGE_DIR = Path(__file__).resolve().parent.parent / PACKAGE

# The boundary's own modules under families/: core, not a family.
BOUNDARY = frozenset({'drive_bridge.families', 'drive_bridge.families.interface', 'drive_bridge.families.parameters',
                      'drive_bridge.families.ports', 'drive_bridge.families.registry', 'drive_bridge.families.errors',
                      'drive_bridge.families.drive_settings', 'drive_bridge.families.edswriter',
                      'drive_bridge.families.node', 'drive_bridge.families.traits'})


def is_core(module: str) -> bool:
    """A module of the core: drive_bridge but the families and the simulator."""
    inside = module.startswith(f'{PACKAGE}.') and not f'{module}.'.startswith(f'{PACKAGE}.sim.')
    return inside and (not module.startswith(f'{PACKAGE}.families.') or module in BOUNDARY)


def family_modules() -> list[str]:
    families = importlib.import_module(f'{PACKAGE}.families')
    return [m.name for m in pkgutil.walk_packages(families.__path__, f'{PACKAGE}.families.') if m.name not in BOUNDARY]


def family_classes() -> Iterator[type]:
    for name in family_modules():
        module = importlib.import_module(name)
        yield from (c for c in vars(module).values() if inspect.isclass(c) and c.__module__ == name)


@functools.cache
def module_tree(module: str) -> ast.Module:
    spec = importlib.util.find_spec(module)
    assert spec is not None and spec.origin is not None
    return ast.parse(Path(spec.origin).read_text(encoding='utf-8'))


def is_private(name: str) -> bool:
    return name.startswith('_') and not name.startswith('__')


def defined_privates(node: ast.ClassDef) -> set[str]:
    """The private members a class defines: methods, class-level names, ``self._x = ...``."""
    names = {n.name for n in node.body if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)}
    names |= {n.target.id for n in node.body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)}
    names |= {t.id for n in node.body if isinstance(n, ast.Assign) for t in n.targets if isinstance(t, ast.Name)}
    names |= {n.attr for n in ast.walk(node) if isinstance(n, ast.Attribute) and isinstance(n.ctx, ast.Store)
              and isinstance(n.value, ast.Name) and n.value.id == 'self'}
    return {n for n in names if is_private(n)}


def class_node(cls: type) -> ast.ClassDef:
    return next(n for n in ast.walk(module_tree(cls.__module__))
                if isinstance(n, ast.ClassDef) and n.name == cls.__name__)


def core_privates(cls: type) -> set[str]:
    """The private members of the core classes ``cls`` inherits from."""
    return set().union(*(defined_privates(class_node(k)) for k in cls.__mro__[1:] if is_core(k.__module__)))


def private_uses(node: ast.ClassDef, privates: set[str]) -> set[str]:
    """Which of ``privates`` a class body reads, writes, calls or overrides (any object's)."""
    used = {n.attr for n in ast.walk(node) if isinstance(n, ast.Attribute) and n.attr in privates}
    return used | {n.name for n in ast.walk(node) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)
                   and n.name in privates}


def any_core_privates() -> set[str]:
    """The private members of every core class (read from the files: nothing is imported)."""
    paths = (p for p in PACKAGE_DIR.rglob('*.py')
             if is_core('.'.join((PACKAGE, *p.relative_to(PACKAGE_DIR).with_suffix('').parts))))
    return set().union(*(defined_privates(n) for p in paths for n in ast.walk(ast.parse(p.read_text(encoding='utf-8')))
                         if isinstance(n, ast.ClassDef)))


def foreign_uses(tree: ast.Module, privates: set[str]) -> set[str]:
    """Which of ``privates`` a module reads off another object than ``self``, ``cls`` or ``super()``."""
    own = {'self', 'cls'}
    return {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and n.attr in privates
            and not (isinstance(n.value, ast.Name) and n.value.id in own)
            and not (isinstance(n.value, ast.Call) and ast.unparse(n.value.func) == 'super')}


def core_private_uses() -> dict[str, set[str]]:
    """Per family module: the core privates its subclasses of core classes touch, and those it
    reads off any other object (unless a class of the module defines the name itself)."""
    found: dict[str, set[str]] = {m: set() for m in family_modules()}
    everywhere = any_core_privates()
    for cls in family_classes():
        found[cls.__module__] |= private_uses(class_node(cls), core_privates(cls))
    for module, used in found.items():
        tree = module_tree(module)
        own = set().union(*(defined_privates(n) for n in ast.walk(tree) if isinstance(n, ast.ClassDef)))
        used |= foreign_uses(tree, everywhere - own)
    return {m: u for m, u in found.items() if u}
