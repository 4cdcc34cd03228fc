"""A vendor simulator (sim/<family>/) reaches the shared simulator and its parts only through
their public members (docs/families.md, "Writing a family and its simulator"): no ``x._name``
on anything but ``self`` or ``cls``, so ``slave.nmt._state``, ``axis.control._axis`` or
``engine._rx_by_cob`` from outside fail here. Read from the source; nothing runs.
"""
from __future__ import annotations

import ast
from pathlib import Path

SIM = Path(__file__).resolve().parents[1] / 'drive_bridge' / 'sim'
VENDORS = ('akd', 'opendrive', 's120', 'servostar')
# (file, expression): today's exceptions, each with its reason
ALLOWED = {
    ('s120/drive.py', 'SimDrive402._axis_count'),  # the slots of the OD, before the S120's own count exists
}


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
