"""Static checks: ruff (lint), mypy (types), lint-imports (the layering contracts).

Each runs the tool from this interpreter's virtualenv with the repository's configuration
(pyproject.toml, .importlinter) and fails with the tool's own report. Deselect them with
``-m "not static"`` (e.g. ``make test ARGS='-m "not static"'``).
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent

pytestmark = pytest.mark.static


def run(*command: str) -> None:
    tool = BIN / command[0]
    if not tool.exists():
        pytest.fail(f'{tool} is missing: run tools/bootstrap.sh (requirements.txt pins it)')
    done = subprocess.run([str(tool), *command[1:]], cwd=REPO, capture_output=True, text=True, timeout=600,
                          check=False)
    assert done.returncode == 0, (f'`{" ".join(command)}` exited with {done.returncode}:\n'
                                  f'{done.stdout}{done.stderr}')


def test_ruff() -> None:
    run('ruff', 'check', '--no-cache', '--output-format', 'concise', 'drive_bridge', 'test', 'bench', 'tools', 'launch')


def test_mypy() -> None:
    # files and per-package strictness from [tool.mypy] in pyproject.toml
    run('mypy', '--config-file', str(REPO / 'pyproject.toml'))


def test_import_contracts() -> None:
    run('lint-imports', str(REPO / '.importlinter'), '--no-cache', '--no-logo')
