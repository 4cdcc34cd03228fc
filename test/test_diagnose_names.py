"""The diagnosis names standard objects and abort codes from a generated table (so that a log
without an EDS does not import canopen): the table must say what canopen says of the shipped
generic CiA 402 EDS, for every object and subindex, and be what the generator writes now."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import canopen
from canopen.sdo.exceptions import SdoAbortedError

from drive_bridge.bag.diagnose import names
from drive_bridge.bag.diagnose.abort_codes import abort_text
from drive_bridge.bag.diagnose.standard_objects import ABORT_TEXTS

ROOT = Path(__file__).resolve().parents[1]
EDS = ROOT / 'drive_bridge' / 'families' / 'generic402' / 'data' / 'generic402.eds'


def test_table_says_what_canopen_reads_for_every_object_and_subindex() -> None:
    od = canopen.import_od(str(EDS), 1)
    indices = sorted(set(od.indices) | {0x1F51, 0x2000, 0x6000, 0x6840, 0x7000})
    checked = 0
    for index in indices:
        for subindex in range(256):
            # what canopen reads of the EDS, as the names module reads a user's EDS
            assert names._standard(index, subindex) == names._from_od(od, index, subindex), (hex(index), subindex)
            checked += 1
    assert checked > 80 * 256


def test_names_of_standard_objects_without_canopen() -> None:
    assert names.object_name(None, 0x1018, 1) == 'Identity object: Vendor-ID'
    assert names.object_name(None, 0x1003, 20) == 'Pre-defined error field: Standard error field 1_14'  # as canopen
    assert names.object_name(None, 0x6841, 0) == 'Statusword (axis 2)'
    assert names.object_name(None, 0x7000, 0) == ''
    assert names.is_signed(None, 0x6064, 0) and not names.is_signed(None, 0x6041, 0)
    assert names.is_signed(None, 0x6864, 0)  # axis 2's position actual value, by slot 0's type


def test_abort_texts_are_canopens() -> None:
    assert ABORT_TEXTS == SdoAbortedError.CODES
    assert abort_text(0x06090030) == 'Value range of parameter exceeded'
    assert abort_text(0x12345678) == 'unknown abort code 0x12345678'


def test_generated_module_is_current() -> None:
    sys.path.insert(0, str(ROOT / 'tools'))
    try:
        import make_standard_objects
    finally:
        sys.path.remove(str(ROOT / 'tools'))
    assert make_standard_objects.OUT.read_text(encoding='utf-8') == make_standard_objects.source(), \
        'run .venv/bin/python tools/make_standard_objects.py'


def test_a_bare_log_is_diagnosed_without_importing_canopen(tmp_path: Path) -> None:
    log = tmp_path / 'abort.log'
    log.write_text('(1.000000) can0 605#4018100100000000\n(1.001000) can0 585#8018100100000206\n'
                   '(1.002000) can0 705#05\n')
    code = ('import sys, contextlib, io\nfrom drive_bridge.cli.main import main\n'
            f'with contextlib.redirect_stdout(io.StringIO()) as out:\n'
            f'    main(["diagnose", {str(log)!r}, "--no-html", "--no-progress"])\n'
            'assert "Vendor-ID" in out.getvalue(), out.getvalue()\n'
            'print(sorted(m for m in sys.modules if m.split(".")[0] in ("canopen", "can", "numpy", "matplotlib")))')
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=120, check=True)
    assert result.stdout.strip() == '[]', result.stdout
