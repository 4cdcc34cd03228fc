"""The package's shape, checked on its import graph, its text and its classes (no ROS, no bus).

What import-linter's contracts (.importlinter) cannot say simply is checked here with grimp,
import-linter's graph library:

- no import cycle between any two modules of drive_bridge, nor between its top-level
  subpackages (cycles listed with the importing lines);
- the generic layers (master, cia402, streaming, ros) name no drive vendor and no
  manufacturer-specific object (index 0x2000..0x5FFF): that knowledge belongs to a family;
- a family (a module under families/ outside the boundary's own) subclasses no core class but
  the documented extension points and error classes, and touches no core class's private
  members (today's exceptions, the SERVOSTAR and S120 axes, listed to shrink to zero); the
  DriveFamily and FamilyNode docstrings' tables name every hook;
- the `ros -> sim` contract really catches the ROS layer reaching into a simulator submodule
  (checked on a scratch copy of the package).

Imports under ``if TYPE_CHECKING:`` are left out, as in .importlinter: they are annotations only.
"""
from __future__ import annotations

import ast
import importlib
import inspect
import re
import shutil
import subprocess
import sys
import textwrap
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path

import grimp
import pytest
from boundarytools import (
    any_core_privates,
    core_private_uses,
    core_privates,
    family_classes,
    foreign_uses,
    is_core,
    private_uses,
)

REPO = Path(__file__).resolve().parent.parent
PACKAGE = 'drive_bridge'
PACKAGE_DIR = REPO / PACKAGE
BIN = Path(sys.executable).parent


@pytest.fixture(scope='module')
def graph() -> grimp.ImportGraph:
    return grimp.build_graph(PACKAGE, exclude_type_checking_imports=True, cache_dir=None)


# --- cycles ---------------------------------------------------------------------------------------

def strongly_connected(edges: Mapping[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of a directed graph (iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, successors = work[-1]
            for succ in successors:
                if succ not in index:
                    index[succ] = low[succ] = len(index)
                    stack.append(succ)
                    on_stack.add(succ)
                    work.append((succ, iter(sorted(edges.get(succ, ())))))
                    break
                if succ in on_stack:
                    low[node] = min(low[node], index[succ])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    components.append(sorted(component))
    return components


def one_cycle(edges: Mapping[str, set[str]], component: list[str]) -> list[str]:
    """A shortest cycle through the component's first member, inside the component."""
    members, start = set(component), component[0]
    previous: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for succ in sorted(edges.get(node, ())):
                if succ not in members:
                    continue
                if succ == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(previous[path[-1]])
                    return [*reversed(path), start]
                if succ not in previous:
                    previous[succ] = node
                    following.append(succ)
        frontier = following
    raise AssertionError(f'no cycle in component {component}')


def import_lines(graph: grimp.ImportGraph, importer: str, imported: str) -> str:
    details = graph.get_import_details(importer=importer, imported=imported)
    return '; '.join(f"l.{d['line_number']}: {d['line_contents']}" for d in details) or '(import)'


def describe_cycles(components: Iterable[list[str]], edges: Mapping[str, set[str]],
                    explain: dict[tuple[str, str], str]) -> str:
    text = []
    for component in components:
        cycle = one_cycle(edges, component)
        text.append(f'cycle among {len(component)} modules ({", ".join(component)}), e.g. '
                    + ' -> '.join(cycle))
        text.extend(f'    {a} -> {b}: {explain[a, b]}' for a, b in zip(cycle, cycle[1:]))
    return '\n'.join(text)


def test_no_module_import_cycle(graph: grimp.ImportGraph) -> None:
    modules = {m for m in graph.modules if m == PACKAGE or m.startswith(PACKAGE + '.')}
    edges = {m: {i for i in graph.find_modules_directly_imported_by(m) if i in modules and i != m}
             for m in modules}
    cycles = [c for c in strongly_connected(edges) if len(c) > 1]
    explain = {(a, b): import_lines(graph, a, b) for a in edges for b in edges[a]}
    assert not cycles, 'import cycles between modules:\n' + describe_cycles(cycles, edges, explain)


def test_no_subpackage_import_cycle(graph: grimp.ImportGraph) -> None:
    """Among drive_bridge's top-level children (packages and modules, as wholes)."""
    children = sorted(graph.find_children(PACKAGE))
    owner = {m: child for child in children for m in {child, *graph.find_descendants(child)}}
    edges: dict[str, set[str]] = {child: set() for child in children}
    explain: dict[tuple[str, str], str] = {}
    for module, child in owner.items():
        for imported in graph.find_modules_directly_imported_by(module):
            target = owner.get(imported)
            if target is None or target == child:
                continue
            edges[child].add(target)
            if (child, target) not in explain:
                explain[child, target] = f'{module} -> {imported} ({import_lines(graph, module, imported)})'
    cycles = [c for c in strongly_connected(edges) if len(c) > 1]
    assert not cycles, 'import cycles between subpackages:\n' + describe_cycles(cycles, edges, explain)


def test_cycle_finder_finds_cycles() -> None:
    edges = {'a': {'b'}, 'b': {'c'}, 'c': {'a', 'd'}, 'd': set(), 'e': {'e'}}
    assert sorted(map(sorted, strongly_connected(edges))) == [['a', 'b', 'c'], ['d'], ['e']]
    assert one_cycle(edges, ['a', 'b', 'c']) == ['a', 'b', 'c', 'a']


# --- no vendor knowledge in the generic layers ---------------------------------------------------

GENERIC = ('master', 'cia402', 'streaming', 'ros', 'bag')

# Word match, case-insensitive; `_` and camelCase humps count as word boundaries (is_akd, SimAkd).
VENDOR = re.compile(r'(?<![a-z0-9])(akd|kollmorgen|servostar|siemens|sinamics|s120|cbc10|open[\s_-]*drive'
                    r'|(?:tde[\s_-]*)?macno)(?![a-z0-9])', re.IGNORECASE)
CAMEL_HUMP = re.compile(r'(?<=[a-z])(?=[A-Z])')

# A manufacturer-specific object index: exactly four hex digits 2000..5FFF, as a 0x literal
# (code, comment or string: 0x2070, 0x2022:04, '0x5FFF') or in CiA/EDS notation (2070h,
# [2022sub4]). Longer literals (0x20000000 flags, 0x00002000 masks) are not indices. A generic
# use of such a number that is not an object index (a bit mask, an EMCY code) says so with
# `# layering: not an index` on its line.
MANUFACTURER_INDEX = re.compile(r'(?<![0-9a-z_])(?:0x([2-5][0-9a-f]{3})(?![0-9a-f_])'
                                r'|([2-5][0-9a-f]{3})(?:h|sub[0-9a-f]+)(?![0-9a-z_]))', re.IGNORECASE)
NOT_AN_INDEX = '# layering: not an index'


def source_lines(subpackage: str) -> Iterator[tuple[str, int, str]]:
    for path in sorted((PACKAGE_DIR / subpackage).rglob('*')):
        if not path.is_file() or '__pycache__' in path.parts:
            continue
        try:
            text = path.read_text(encoding='utf-8')
        except UnicodeDecodeError:
            continue
        for number, line in enumerate(text.splitlines(), 1):
            yield str(path.relative_to(REPO)), number, line


def vendor_names(line: str) -> list[str]:
    return [m.group(1) for m in VENDOR.finditer(CAMEL_HUMP.sub(' ', line))]


def manufacturer_indices(line: str) -> list[str]:
    if NOT_AN_INDEX in line:
        return []
    return [m.group(0) for m in MANUFACTURER_INDEX.finditer(line)]


def findings(check: Callable[[str], list[str]]) -> list[str]:
    return [f'{path}:{number}: {", ".join(found)}: {line.strip()}'
            for sub in GENERIC for path, number, line in source_lines(sub) if (found := check(line))]


def test_generic_layers_name_no_vendor() -> None:
    found = findings(vendor_names)
    assert not found, ('vendor names in the generic layers (a family says what is vendor-specific):\n'
                       + '\n'.join(found))


def test_generic_layers_use_no_manufacturer_object() -> None:
    found = findings(manufacturer_indices)
    assert not found, ('manufacturer-specific objects (0x2000..0x5FFF) in the generic layers '
                       f'(a family names them; `{NOT_AN_INDEX}` marks a number that is none):\n'
                       + '\n'.join(found))


@pytest.mark.parametrize('line', [
    'AKD = 1', 'from drive_bridge.families.akd import X', 'def is_akd(): ...', 'class SimAkd:',
    '# Kollmorgen SERVOSTAR 600', 'siemens', 'SINAMICS S120 with CBC10', "'OPEN drive'", 'OpenDrive',
    'open_drive', 'TDE Macno', 'tde_macno'])
def test_vendor_detector_hits(line: str) -> None:
    assert vendor_names(line)


@pytest.mark.parametrize('line', ['backed = 1', 'akdx = 2', 's1200', 'opened drives', 'cbc100', 'reopen drive'])
def test_vendor_detector_misses(line: str) -> None:
    assert not vendor_names(line)


@pytest.mark.parametrize('line', [
    'X = 0x2070', 'sdo.read(0x2022, 4)', '# object 0x5FFF', "'0x2022:04'", 'SCALE = (0X3000, 1)',
    '# the drive maps 2070h', "'[2022sub4]'"])
def test_index_detector_hits(line: str) -> None:
    assert manufacturer_indices(line)


@pytest.mark.parametrize('line', [
    'X = 0x6064', 'Y = 0x1A00', 'FLAG = 0x20000000', 'MASK = 0x00002000', 'A = 0x1FFF', 'B = 0x6000',
    'C = 0x200', "name = 'ax2070h'", 'BIT13 = 0x2000  # layering: not an index', 'v_2070h = 1'])
def test_index_detector_misses(line: str) -> None:
    assert not manufacturer_indices(line)


# --- the family boundary --------------------------------------------------------------------------

# Where a family extends the core (docs/families.md): these classes, and any error class.
# JointDriverBase (joint/driverbase.py): the plumbing every joint driver shares, all of it public; a
# family's own joint driver (a drive without CiA 402: the OPEN drive's RunLogicDriver) builds on it.
EXTENSION_POINTS = frozenset({'drive_bridge.families.interface.DriveFamily',
                              'drive_bridge.families.node.FamilyNode',
                              'drive_bridge.families.parameters.ParameterAccess',
                              'drive_bridge.cia402.quirks.AxisQuirks',
                              'drive_bridge.joint.driverbase.JointDriverBase'})
# Exceptions: none since issue 23 (the SERVOSTAR and S120 hand the CiA 402 Axis their AxisQuirks
# instead of subclassing it). Both must stay empty: a family that needs more of the core asks for
# a hook or a part; remove what is no longer used (the test says so), never add.
AXIS_SUBCLASSES: dict[str, str] = {}
CORE_PRIVATES_USED: dict[str, frozenset[str]] = {}


def test_families_subclass_only_extension_points() -> None:
    """A family's classes subclass DriveFamily, FamilyNode, ParameterAccess, AxisQuirks,
    JointDriverBase, error classes or none of the core."""
    wrong, kept = [], set()
    for cls in family_classes():
        for base in cls.__bases__:
            name, base_name = f'{cls.__module__}.{cls.__qualname__}', f'{base.__module__}.{base.__qualname__}'
            if not is_core(base.__module__) or base_name in EXTENSION_POINTS or issubclass(base, BaseException):
                continue
            if AXIS_SUBCLASSES.get(name) == base_name:
                kept.add(name)
            else:
                wrong.append(f'{name} subclasses the core class {base_name}')
    assert not wrong, ('a family extends the core through the EXTENSION_POINTS and error classes only:\n'
                       + '\n'.join(wrong))
    assert kept == set(AXIS_SUBCLASSES), (
        f'no longer subclassed, remove from AXIS_SUBCLASSES: {set(AXIS_SUBCLASSES) - kept}')


def test_families_touch_no_new_core_private() -> None:
    """A family touches no private member of a core class beyond today's listed ones."""
    found = core_private_uses()
    new = {m: sorted(n) for m, u in found.items() if (n := u - CORE_PRIVATES_USED.get(m, frozenset()))}
    gone = {m: sorted(g) for m, u in CORE_PRIVATES_USED.items() if (g := u - found.get(m, set()))}
    assert not new, f"a family touches a core class's private members (ask for a hook or a part instead): {new}"
    assert not gone, f'no longer used, remove from CORE_PRIVATES_USED: {gone}'


def test_private_use_finders() -> None:
    """A subclass's overrides and uses of the core's privates are found, its own are not; so are
    privates read off another object anywhere in a module."""
    from drive_bridge.cia402.axis import Axis
    tree = ast.parse(textwrap.dedent('''
        class Quirky(Axis):
            def _write(self, key, value): ...  # an override
            def run(self, other):
                self._mode = 3
                return other._device_command(), self._own, super()._hold_stale()

        def peek(axis):
            return axis._target_state, axis._not_a_core_name
    '''))
    node = next(n for n in ast.walk(tree) if isinstance(n, ast.ClassDef))
    assert private_uses(node, core_privates(type('Quirky', (Axis,), {}))) == {'_write', '_mode', '_device_command',
                                                                               '_hold_stale'}
    assert foreign_uses(tree, any_core_privates()) == {'_device_command', '_target_state'}


@pytest.mark.parametrize('module, cls', [('interface', 'DriveFamily'), ('node', 'FamilyNode')])
def test_drive_family_table_names_every_hook(module: str, cls: str) -> None:
    """The hook table of the DriveFamily (FamilyNode) docstring lists every public method."""
    mod = importlib.import_module(f'drive_bridge.families.{module}')
    hooks = [n for n, v in vars(getattr(mod, cls)).items() if not n.startswith('_') and inspect.isfunction(v)]
    missing = [h for h in hooks if f'``{h}``' not in (mod.__doc__ or '')]
    assert not missing, f'hooks missing from the table in drive_bridge/families/{module}.py: {missing}'


def test_axis_quirks_table_names_every_hook() -> None:
    """The hook table of the AxisQuirks module docstring lists every public method."""
    from drive_bridge.cia402 import quirks
    hooks = [n for n, v in vars(quirks.AxisQuirks).items() if not n.startswith('_') and inspect.isfunction(v)]
    missing = [h for h in hooks if f'``{h}``' not in (quirks.__doc__ or '')]
    assert hooks and not missing, f'hooks missing from the table in drive_bridge/cia402/quirks.py: {missing}'


# --- the ros -> sim contract bites ----------------------------------------------------------------

@pytest.mark.parametrize('injected', [
    'from drive_bridge.sim.slave import SimulatedSlave',
    'from drive_bridge.sim import slave',
    'import drive_bridge.sim.slave',
])
def test_ros_sim_contract_catches_submodule_import(tmp_path: Path, injected: str) -> None:
    """A scratch copy whose ROS layer imports a simulator submodule breaks `ros-sim-facade`."""
    shutil.copytree(PACKAGE_DIR, tmp_path / PACKAGE, ignore=shutil.ignore_patterns('__pycache__'))
    target = tmp_path / PACKAGE / 'ros' / 'scratch_sim_user.py'
    target.write_text(f'"""Scratch module (test only)."""\n{injected}  # injected\n', encoding='utf-8')
    broken = run_contract(tmp_path)
    assert broken.returncode != 0 and 'drive_bridge.ros.scratch_sim_user -> drive_bridge.sim.slave' in broken.stdout, (
        f'the ros-sim-facade contract missed {injected!r}:\n{broken.stdout}{broken.stderr}')
    target.write_text('"""Scratch module (test only)."""\nfrom drive_bridge.sim import SimulatedBus  # injected\n',
                      encoding='utf-8')
    facade = run_contract(tmp_path)
    assert 'drive_bridge.ros.scratch_sim_user' not in facade.stdout, (
        f'the ros-sim-facade contract refused the package import:\n{facade.stdout}{facade.stderr}')


def run_contract(root: Path) -> subprocess.CompletedProcess[str]:
    """lint-imports on the copy under `root` (its cwd goes first on sys.path), one contract only."""
    return subprocess.run(
        [str(BIN / 'lint-imports'), str(REPO / '.importlinter'), '--contract', 'ros-sim-facade', '--no-logo',
         '--no-cache'], cwd=root, capture_output=True, text=True, timeout=120, check=False)
