"""`drive-bridge diagnose`, with no config, no EDS and no flags, on every real log of the corpus
(test/data/traces/expectations.yaml: logs pasted into public issue threads, and the repository
traces of ../shared/realdata): it says each event an expert reads in the log, and nothing an
expert would call false (every error or warning is one of the events or a true finding the
expectations list as tolerated)."""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
from typing import Any

import pytest
from corpustools import check_facts, corpus, ours_found, path_of, score

from drive_bridge.cli.main import main

LOGS = corpus()


def diagnose_json(path: Path, tmp: Path) -> dict[str, Any]:
    out = tmp / f'{path.name}.json'
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(['diagnose', str(path), '--no-html', '--json', str(out), '--no-progress']) == 0
    data: dict[str, Any] = json.loads(out.read_text(encoding='utf-8'))
    return data


def test_the_corpus_has_15_real_logs_of_5_origins() -> None:
    assert len(LOGS) >= 15 and len({log['origin'] for log in LOGS}) >= 5
    for log in LOGS:
        assert path_of(log).is_file(), log['file']
        assert log['source'].startswith('https://') and log['licence'] and log['expert']
    listed = {log['file'] for log in LOGS if log['dir'] == 'test'}
    on_disk = {p.name for p in path_of({'dir': 'test', 'file': ''}).iterdir() if p.suffix in ('.log', '.txt')}
    assert listed == on_disk


@pytest.mark.parametrize('log', LOGS, ids=[log['file'] for log in LOGS])
def test_diagnose_says_what_an_expert_reads(log: dict[str, Any], tmp_path: Path) -> None:
    data = diagnose_json(path_of(log), tmp_path)
    result = score(log, 'ours', ours_found(data), data)
    assert not result.missed and not result.wrong, (result.missed, result.wrong, data['verdict'])
    assert not result.false, result.false
    assert not check_facts(log, data)
    assert data['verdict']
