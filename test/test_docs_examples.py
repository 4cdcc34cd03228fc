"""The docs stay true: every ``ros2`` example of docs/interfaces.md runs against a bridge (the
demo; the vendor-parameter block against the AKD example; the lifecycle block against the
managed demo) through the stand-in of test/ros2cli.py, the relative links of README.md and
docs/*.md resolve, and the EDS table of docs/families.md is the one test_any402.py checks.

An example passes when its request is accepted by the types (field names, nesting, types as
``ros2`` reads them) and the bridge answers success; one whose comment says "refused" must be
answered with success false and a reason.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml

import ros2cli
from rostools import interrupt, output, spawn

REPO = Path(__file__).resolve().parent.parent
DOCS = REPO / 'docs'
INTERFACES = DOCS / 'interfaces.md'
ROS2_LINE = re.compile(r'^ros2 (?:service|topic|action|param|lifecycle) .*$', re.M)


def bash_blocks(path: Path) -> list[str]:
    return re.findall(r'```bash\n(.*?)```', path.read_text(encoding='utf-8'), re.S)


def ros2_lines(block: str) -> list[str]:
    return [line.strip() for line in ROS2_LINE.findall(block)]


def blocks_of(kind: str) -> list[str]:
    """The interfaces page's ros2 lines: 'akd' (the vendor-parameter block), 'lifecycle', or
    'demo' (every other block)."""
    lines: list[str] = []
    for block in bash_blocks(INTERFACES):
        found = ros2_lines(block)
        if not found:
            continue
        which = 'akd' if 'akd_pvt_example.yaml' in block else 'lifecycle' if 'ros2 lifecycle' in block else 'demo'
        if which == kind:
            lines.extend(found)
    return lines


def check_answer(line: str, answer: object) -> None:
    refused = 'refused' in line.partition('#')[2]
    for field in ('success', 'successful'):
        if hasattr(answer, field):
            ok = getattr(answer, field)
            reason = getattr(answer, 'message', getattr(answer, 'reason', ''))
            if refused:
                assert not ok and reason, f'{line}\n  was not refused: {answer}'
            else:
                assert ok, f'{line}\n  failed: {reason}'
            return
    if hasattr(answer, 'error_code'):  # an action result
        assert answer.error_code == 0, f'{line}\n  ended {answer.error_code}: {answer.error_string}'


@pytest.fixture
def bridge(tmp_path: Path) -> Iterator[callable]:
    """Start ``bridge``/``bridge_managed`` with a config in its own process (stopped after)."""
    procs: list[subprocess.Popen] = []

    def start(executable: str, config: Path, *ros_args: str) -> subprocess.Popen:
        # heartbeat timeouts of 1 s instead of 300 ms, as test_setup's demo: a process joining the
        # ROS graph can stall the demo's process for ~0.4 s on a loaded machine
        data = yaml.safe_load(config.read_text())
        data.setdefault('options', {})['heartbeat_multiplier'] = 10
        local = tmp_path / config.name
        local.write_text(yaml.safe_dump(data, sort_keys=False))
        args = [str(Path(sys.prefix) / 'bin' / executable), str(local)]
        if ros_args:
            args += ['--ros-args', *ros_args]
        proc = spawn(args, tmp_path / f'{executable}-{len(procs)}.log', env=dict(os.environ), cwd=tmp_path,
                     start_new_session=True)
        procs.append(proc)
        return proc

    yield start
    for proc in procs:
        interrupt(proc)


def run_lines(lines: list[str], proc: subprocess.Popen) -> None:
    assert lines
    session = ros2cli.Session()
    try:
        session.echo('/drive_bridge/axis_states', 1)  # the bridge is up
        for line in lines:
            assert proc.poll() is None, f'the bridge ended before {line}: {output(proc)[-2000:]}'
            try:
                answer = ros2cli.run(ros2cli.split_command(line), session)
            except ros2cli.CliError as exc:
                pytest.fail(f'{line}\n  {exc}')
            check_answer(line, answer)
    finally:
        session.close()


def readme_demo_lines() -> list[str]:
    section = (REPO / 'README.md').read_text(encoding='utf-8').split('## The demo', 1)[1].split('\n## ', 1)[0]
    return ros2_lines('\n'.join(re.findall(r'```bash\n(.*?)```', section, re.S)))


@pytest.mark.slow
def test_interfaces_examples_run_against_the_demo(bridge) -> None:
    lines = [*blocks_of('demo'), *readme_demo_lines()]  # the README's moves the joints: after the commands at 0.0
    assert any('follow_joint_trajectory' in line for line in lines)
    proc = bridge('bridge', REPO / 'config' / 'demo.yaml', '-p', 'auto_enable:=true')
    run_lines(lines, proc)


def test_interfaces_parameter_examples_run_against_the_akd_example(bridge) -> None:
    lines = blocks_of('akd')
    assert {'param_read', 'param_write', 'param_save'} <= {w.rsplit('/', 1)[-1] for line in lines for w in line.split()}
    proc = bridge('bridge', REPO / 'config' / 'akd_pvt_example.yaml', '-p', 'auto_enable:=true')
    run_lines(lines, proc)


@pytest.mark.slow
def test_interfaces_lifecycle_examples_drive_the_managed_node(bridge) -> None:
    lines = blocks_of('lifecycle')
    proc = bridge('bridge_managed', REPO / 'config' / 'demo.yaml')
    session = ros2cli.Session()
    try:
        for line in lines:
            assert proc.poll() is None
            answer = ros2cli.run(ros2cli.split_command(line), session)
            check_answer(line, answer)
        state = ros2cli.run(['lifecycle', 'get', '/drive_bridge'], session)
        assert state.current_state.label == 'active'
    finally:
        session.close()


def test_every_service_topic_and_parameter_has_an_example() -> None:
    """The services the bridge creates (ros/*.py), its topics and its parameters each appear
    in a ros2 example of the interfaces page."""
    examples = '\n'.join(ros2_lines('\n'.join(bash_blocks(INTERFACES))))
    services = set()
    for source in (REPO / 'drive_bridge' / 'ros').glob('*.py'):
        services |= set(re.findall(r"create_service\(\w+, '~/(\w+)'", source.read_text()))
    services |= {'enable', 'disable', 'halt', 'resume', 'quick_stop', 'fault_reset', 'recover', 'home'}
    def shown(name: str) -> bool:
        return re.search(rf'{re.escape(name)}(\s|$)', examples, re.M) is not None
    missing = sorted(s for s in services if not shown(f'/drive_bridge/{s}'))
    assert not missing, f'services without a ros2 example in docs/interfaces.md: {missing}'
    topics = ['/joint_states', '/drive_bridge/axis_states', '/drive_bridge/emcy', '/drive_bridge/command_errors',
              '/diagnostics', '/drive_bridge/can_frames', '/drive_bridge/joint_trajectory', '/drive_bridge/commands',
              '/drive_bridge/joint_commands', '/drive_bridge/follow_joint_trajectory']
    assert not [t for t in topics if not shown(t)]
    from drive_bridge.ros.parameters import RUN_TIME, START_TIME
    text = INTERFACES.read_text(encoding='utf-8')
    assert not [p for p in (*START_TIME, *RUN_TIME) if f'`{p}`' not in text]


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r'[^\w\- ]', '', heading.strip().lower()).replace(' ', '-')


def without_code(text: str) -> str:
    return re.sub(r'```.*?```', '', text, flags=re.S)


def test_relative_links_of_the_docs_resolve() -> None:
    broken = []
    for page in [REPO / 'README.md', *sorted(DOCS.glob('*.md'))]:
        for target in re.findall(r'\]\(([^)\s]+)\)', without_code(page.read_text(encoding='utf-8'))):
            if target.startswith(('http://', 'https://')):
                continue
            file, _, anchor = target.partition('#')
            dest = (page.parent / file).resolve() if file else page
            if not dest.exists():
                broken.append(f'{page.name}: {target} (no such file)')
            elif anchor and dest.suffix == '.md':
                headings = re.findall(r'^#+ (.*)$', without_code(dest.read_text(encoding='utf-8')), re.M)
                if anchor not in {slug(h) for h in headings}:
                    broken.append(f'{page.name}: {target} (no such heading)')
    assert not broken, '\n'.join(broken)


def test_the_readme_stays_a_door() -> None:
    lines = (REPO / 'README.md').read_text(encoding='utf-8').count('\n')
    assert lines <= 300, f'README.md has {lines} lines; move the details into docs/'


def test_the_families_doc_shows_the_table_test_any402_checks() -> None:
    from test_any402 import EXPECTED
    text = (DOCS / 'families.md').read_text(encoding='utf-8').split('## Any CiA 402 drive', 1)[1]
    rows = [[cell.strip() for cell in line.split('|')[1:-1]] for line in text.splitlines()
            if re.match(r'^\| \S+\.(eds|dcf) \|', line)]
    documented = {name: (rpdos, tpdos, polled, mode) for name, rpdos, tpdos, polled, mode, _why in rows}
    assert documented == EXPECTED
