"""A vendor simulator (sim/<family>/) reaches the shared simulator and its parts only through
their public members (docs/families.md, "Writing a family and its simulator"): no ``x._name``
on anything but ``self`` or ``cls``, so ``slave.nmt._state``, ``axis.control._axis`` or
``engine._rx_by_cob`` from outside fail here; nor does a vendor class touch (read, write, call
or override) a private member of the shared simulator class it subclasses (``PdoEngine``,
``EmcyProducer``, ``Axis402``, ``SimDrive402``, ...): their documented public members are the
extension surface. Read from the source; nothing runs.
"""
from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import textwrap
from collections.abc import Iterator
from pathlib import Path

from boundarytools import class_node, defined_privates, private_uses

SIM = Path(__file__).resolve().parents[1] / 'drive_bridge' / 'sim'
VENDORS = ('akd', 'opendrive', 's120', 'servostar')
# (file, expression): today's exceptions, each with its reason (none)
ALLOWED: set[tuple[str, str]] = set()
# (vendor class, private member of a shared base): today's exceptions, each with its reason (none)
SHARED_PRIVATES_ALLOWED: set[tuple[str, str]] = set()


def foreign_privates(path: Path) -> list[tuple[int, str]]:
    """(line, expression) of every private member read or written on something not self/cls."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if not isinstance(node, ast.Attribute) or not node.attr.startswith('_') or node.attr.startswith('__'):
            continue
        if isinstance(node.value, ast.Name) and node.value.id in ('self', 'cls'):
            continue
        found.append((node.lineno, ast.unparse(node)))
    return found


def test_vendor_simulators_use_no_private_member_of_another_object() -> None:
    found = {(str(path.relative_to(SIM)), line, expression)
             for vendor in VENDORS for path in sorted((SIM / vendor).glob('*.py'))
             for line, expression in foreign_privates(path)}
    unexpected = sorted(f'{file}:{line}: {expression}' for file, line, expression in found
                        if (file, expression) not in ALLOWED)
    assert not unexpected, 'vendor simulators reach into private members:\n' + '\n'.join(unexpected)
    stale = ALLOWED - {(file, expression) for file, _line, expression in found}
    assert not stale, f'listed exceptions no longer occur (remove them): {sorted(stale)}'


def test_the_check_sees_a_part_s_private_member(tmp_path: Path) -> None:
    probe = tmp_path / 'probe.py'
    probe.write_text('def f(slave):\n    return slave.nmt._state, self._own\n')
    assert foreign_privates(probe) == [(2, 'slave.nmt._state')]


def is_shared_sim(module: str) -> bool:
    """A module of the shared simulator: drive_bridge.sim but a vendor's sim/<family>/."""
    parts = module.split('.')
    return parts[:2] == ['drive_bridge', 'sim'] and (len(parts) < 3 or parts[2] not in VENDORS)


def vendor_sim_classes() -> Iterator[type]:
    for vendor in VENDORS:
        package = importlib.import_module(f'drive_bridge.sim.{vendor}')
        for info in pkgutil.walk_packages(package.__path__, f'{package.__name__}.'):
            module = importlib.import_module(info.name)
            yield from (c for c in vars(module).values() if inspect.isclass(c) and c.__module__ == info.name)


def shared_base_privates(cls: type) -> set[str]:
    """The private members of the shared simulator classes ``cls`` inherits from."""
    return set().union(*(defined_privates(class_node(k)) for k in cls.__mro__[1:] if is_shared_sim(k.__module__)))


def test_vendor_simulators_touch_no_private_member_of_their_shared_bases() -> None:
    found = {(f'{cls.__module__}.{cls.__qualname__}', name) for cls in vendor_sim_classes()
             for name in private_uses(class_node(cls), shared_base_privates(cls))}
    unexpected = sorted(f'{owner}: {name}' for owner, name in found - SHARED_PRIVATES_ALLOWED)
    assert not unexpected, ('vendor simulators touch private members of the shared simulator classes they '
                            'extend (give the base a documented public member instead):\n' + '\n'.join(unexpected))
    stale = SHARED_PRIVATES_ALLOWED - found
    assert not stale, f'listed exceptions no longer occur (remove them): {sorted(stale)}'


def test_the_check_sees_a_shared_base_s_private_member() -> None:
    from drive_bridge.sim.pdo import PdoEngine
    tree = ast.parse(textwrap.dedent('''
        class Probe(PdoEngine):
            def _compile(self, pdo): ...  # an override
            def written(self, index):
                self._refresh()
                return self.store, self.by_index, self._own
    '''))
    node = next(n for n in ast.walk(tree) if isinstance(n, ast.ClassDef))
    assert private_uses(node, shared_base_privates(type('Probe', (PdoEngine,), {}))) == {'_compile', '_refresh'}
    assert is_shared_sim('drive_bridge.sim.pdo') and not is_shared_sim('drive_bridge.sim.s120.pdo')
