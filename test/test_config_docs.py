"""The complete example in docs/configuration.md loads (the reference stays true)."""
from __future__ import annotations

import re
from pathlib import Path

from configtools import CONFIGS, REAL_EDS, load_yaml

DOC = Path(__file__).resolve().parents[1] / 'docs' / 'configuration.md'


def test_documented_complete_example_loads(tmp_path: Path) -> None:
    text = DOC.read_text(encoding='utf-8')
    section = text.split('## Complete example', 1)[1]
    example = re.search(r'```yaml\n(.*?)```', section, re.S)
    assert example is not None
    (tmp_path / 'eds').mkdir()
    (tmp_path / 'eds' / 'technosoft.eds').write_bytes((REAL_EDS / 'technosoft.eds').read_bytes())
    (tmp_path / 'eds' / 'io_module.eds').write_bytes((CONFIGS / 'io_module.eds').read_bytes())
    config = load_yaml(tmp_path, example.group(1))
    assert [n.name for n in config.nodes] == ['shoulder', 'slide', 'io']
    assert [a.joint for _, a in config.axes] == ['shoulder_pan', 'shoulder_lift', 'slide']
    assert config.bus.interface == 'socketcan' and config.master.sync_period == 0.004
    assert config.warnings == ()
    access = config.access
    assert access.sdo_write.allows(9, 0x6200) and not access.sdo_write.allows(9, 0x6040)
    assert access.sdo_write.allows(5, 0x6040) and not access.sdo_write.allows(5, 0x1017)
    assert access.nmt.node_ids == {5, 6} and not access.nmt.allows(9, {5, 6, 9})
